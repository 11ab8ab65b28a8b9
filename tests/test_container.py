"""The container image, built and run for real.

Builds ``Dockerfile`` at the repository root, starts the image with its own entrypoint and command,
and checks what a deployment relies on: ``/liveness`` answers, ``/`` serves the Panel app, the
server process is not root, the numba cache is writable, the HEALTHCHECK command passes, and the
command line is the production one (threads, signed sessions, no --admin/--autoreload).

Engine: ``docker`` if ``docker info`` works, else podman through ``shared/tools/oci-build-run``
(a sibling of the repository; needs root). With neither, the test skips, except under CI (``CI``
set), where it fails: a CI run that silently never built the image would prove nothing.

Environment: ``CONTAINER_CONTEXT`` builds another directory instead of the repository root;
``CONTAINER_BUILD_TIMEOUT`` (seconds, default 1800: a fresh machine first debootstraps the base).
"""

from __future__ import annotations

import json
import os
import shutil
import socket
import subprocess
import time
import urllib.error
import urllib.request
from pathlib import Path

import pytest

from support.server import SERVER_ENV

#: Runs alone, after the rest (``pytest -m serial``; tests/conftest.py):
SERIAL = "it builds and runs the container image"

pytestmark = pytest.mark.container

REPO = Path(__file__).resolve().parents[1]
CONTEXT = Path(os.environ.get("CONTAINER_CONTEXT", str(REPO))).resolve()
OCI_BUILD_RUN = Path(__file__).resolve().parents[2] / "shared" / "tools" / "oci-build-run"
TAG = "dipole-observability-test"
PORT = 5006  # the port the image's CMD and HEALTHCHECK use
BUILD_TIMEOUT = float(os.environ.get("CONTAINER_BUILD_TIMEOUT", "1800"))
START_TIMEOUT = 120.0  # seconds from `run` until /liveness answers


def _in_ci() -> bool:
    return os.environ.get("CI", "").strip().lower() not in ("", "0", "false", "no")


def _unavailable(reason: str):
    if _in_ci():
        pytest.fail(f"container test cannot run under CI: {reason}")
    pytest.skip(reason)


def _sh(args, timeout=120.0, check=True, **kw) -> subprocess.CompletedProcess:
    proc = subprocess.run(
        [str(a) for a in args], capture_output=True, text=True, timeout=timeout, check=False, **kw
    )
    if check and proc.returncode != 0:
        pytest.fail(
            f"{' '.join(map(str, args))} exited {proc.returncode}\n"
            f"--- stdout (tail) ---\n{proc.stdout[-4000:]}\n--- stderr (tail) ---\n{proc.stderr[-4000:]}"
        )
    return proc


def _docker_works() -> bool:
    if shutil.which("docker") is None:
        return False
    try:
        proc = subprocess.run(["docker", "info"], capture_output=True, timeout=60, check=False)
    except subprocess.TimeoutExpired:
        return False
    return proc.returncode == 0


def _port_free(port: int) -> bool:
    with socket.socket() as s:
        try:
            s.bind(("0.0.0.0", port))
        except OSError:
            return False
    return True


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _get(url: str, timeout: float = 30.0) -> tuple[int, str]:
    with urllib.request.urlopen(url, timeout=timeout) as resp:
        return resp.status, resp.read().decode("utf-8", "replace")


class Engine:
    """docker, or podman via oci-build-run (which runs containers on the host network)."""

    def __init__(self):
        if _docker_works():
            self.kind, self.cli = "docker", ["docker"]
        elif not OCI_BUILD_RUN.is_file():
            _unavailable(f"`docker info` fails and {OCI_BUILD_RUN} does not exist")
        elif os.geteuid() != 0:
            _unavailable(f"`docker info` fails and {OCI_BUILD_RUN} needs root")
        else:
            self.kind, self.cli = "podman", ["podman"]
        self.image = TAG if self.kind == "docker" else f"localhost/{TAG}"

    def build(self) -> float:
        t0 = time.monotonic()
        if self.kind == "docker":
            _sh(["docker", "build", "-t", TAG, CONTEXT], timeout=BUILD_TIMEOUT)
        else:
            # podman's default OCI image format drops HEALTHCHECK; the docker format keeps it.
            env = {**os.environ, "BUILDAH_FORMAT": "docker"}
            _sh(["bash", OCI_BUILD_RUN, "build", CONTEXT, TAG], timeout=BUILD_TIMEOUT, env=env)
        return time.monotonic() - t0

    def inspect(self) -> dict:
        return json.loads(_sh([*self.cli, "image", "inspect", self.image]).stdout)[0]

    def run(self, config: dict) -> tuple[str, int]:
        """Start the image as configured; return (container id, host port it answers on)."""
        if self.kind == "docker":
            port = _free_port()
            out = _sh(["docker", "run", "-d", "-p", f"127.0.0.1:{port}:{PORT}", self.image])
        elif _port_free(PORT):
            port = PORT
            out = _sh(["bash", OCI_BUILD_RUN, "run", TAG])
        else:
            # Host network and 5006 taken (a dev server?): the image's own entrypoint and command
            # with only the port changed, so that the other server cannot answer for this one.
            port = _free_port()
            argv = [str(port) if a == str(PORT) else a for a in config["Cmd"]]
            entry = json.dumps([*(config.get("Entrypoint") or []), *argv])
            out = _sh(["bash", OCI_BUILD_RUN, "run", TAG, "--entrypoint", entry])
        return out.stdout.strip().splitlines()[-1], port

    def exec(self, cid: str, *args: str, check=True) -> subprocess.CompletedProcess:
        return _sh([*self.cli, "exec", cid, *args], check=check)

    def running(self, cid: str) -> bool:
        proc = _sh([*self.cli, "inspect", "--format", "{{.State.Running}}", cid], check=False)
        return proc.stdout.strip() == "true"

    def logs(self, cid: str) -> str:
        proc = _sh([*self.cli, "logs", cid], check=False)
        return (proc.stdout + proc.stderr)[-4000:]

    def stop(self, cid: str) -> None:
        if self.kind == "docker":
            _sh(["docker", "rm", "-f", cid], check=False)
        else:
            _sh(["bash", OCI_BUILD_RUN, "stop", cid], check=False)


@pytest.fixture(scope="module")
def engine() -> Engine:
    return Engine()


@pytest.fixture(scope="module")
def image(engine) -> dict:
    if not (CONTEXT / "Dockerfile").is_file():
        pytest.fail(f"no Dockerfile in build context {CONTEXT}")
    seconds = engine.build()
    print(f"image {engine.image} built by {engine.kind} in {seconds:.0f} s")
    return engine.inspect()


def _config(image: dict) -> dict:
    return image.get("Config") or {}


@pytest.fixture(scope="module")
def server(engine, image):
    """A running container: yields (engine, container id, base URL); always removed afterwards."""
    cid, port = engine.run(_config(image))
    try:
        base = f"http://127.0.0.1:{port}"
        deadline, last = time.monotonic() + START_TIMEOUT, None
        while True:
            try:
                status, body = _get(f"{base}/liveness", timeout=5)
                if status == 200:
                    break
                last = f"HTTP {status}: {body[:200]}"
            except (OSError, urllib.error.URLError) as exc:
                last = repr(exc)
            if not engine.running(cid):
                pytest.fail(f"container exited before /liveness answered\n{engine.logs(cid)}")
            if time.monotonic() > deadline:
                pytest.fail(
                    f"/liveness did not answer within {START_TIMEOUT:.0f} s (last: {last})\n"
                    f"--- container log ---\n{engine.logs(cid)}"
                )
            time.sleep(1)
        # First page: builds the first session (~6 s; more if the numba cache were cold). Load it
        # once here with room for that, so the tests below see the server as later visitors do.
        _get(f"{base}/", timeout=300)
        yield engine, cid, base
    finally:
        engine.stop(cid)


def test_image_runs_production_command_as_non_root(image):
    cfg = _config(image)
    cmd = cfg["Cmd"]
    assert cmd[:2] == ["panel", "serve"], cmd
    args = " ".join(cmd)
    for expected in (
        "--address 0.0.0.0",
        f"--port {PORT}",
        "--liveness",
        "--num-threads 4",
        "--session-ids signed",
        "--check-unused-sessions",
        "--unused-session-lifetime",
    ):
        assert expected in args, f"{expected!r} missing from CMD {cmd}"
    for forbidden in ("--admin", "--autoreload", "--dev", "--num-procs"):
        assert forbidden not in args, f"{forbidden!r} in CMD {cmd}"

    user = cfg.get("User", "")
    assert user and user.split(":")[0] not in ("0", "root"), f"image USER is {user!r}"
    assert f"{PORT}/tcp" in (cfg.get("ExposedPorts") or {})

    env = dict(e.split("=", 1) for e in cfg.get("Env", []))
    origins = env.get("BOKEH_ALLOW_WS_ORIGIN", "")
    assert origins and "*" not in origins, f"BOKEH_ALLOW_WS_ORIGIN={origins!r}"
    assert env.get("NUMBA_CACHE_DIR", "").startswith("/home/"), env
    for name, value in SERVER_ENV.items():  # what the load test measured memory with
        assert env.get(name) == value, f"{name}={env.get(name)!r} in the image, {value!r} expected"

    health = cfg.get("Healthcheck") or image.get("Healthcheck")
    assert health, "image has no HEALTHCHECK"
    assert f"127.0.0.1:{PORT}/liveness" in " ".join(health["Test"]), health


def test_liveness_answers(server):
    _, _, base = server
    status, body = _get(f"{base}/liveness")
    assert status == 200
    assert json.loads(body) == {"/liveness": True}


def test_root_serves_the_panel_app(server):
    _, _, base = server
    status, body = _get(f"{base}/")
    assert status == 200
    assert "bokeh" in body.lower(), body[:500]
    # The document is embedded for a (signed) session, not an error or directory page.
    assert "Bokeh.embed" in body or "embed_items" in body, body[:500]


def test_server_process_is_not_root(server):
    engine, cid, _ = server
    # PID 1 is the server itself: the entrypoint shell execs into `panel serve`.
    cmdline = engine.exec(cid, "cat", "/proc/1/cmdline").stdout.split("\0")
    assert "panel" in " ".join(cmdline) and "serve" in cmdline, cmdline
    status = engine.exec(cid, "cat", "/proc/1/status").stdout
    uids = next(line.split()[1:] for line in status.splitlines() if line.startswith("Uid:"))
    assert uids and all(u != "0" for u in uids), f"server runs with uids {uids}"


def test_numba_cache_dir_is_writable(server):
    engine, cid, _ = server
    probe = (
        "import os, tempfile; d = os.environ['NUMBA_CACHE_DIR']; "
        "tempfile.NamedTemporaryFile(dir=d).close(); print(d)"
    )
    assert engine.exec(cid, "python", "-c", probe).stdout.strip().endswith("numba")


def test_healthcheck_command_passes(server, image):
    engine, cid, _ = server
    test = (_config(image).get("Healthcheck") or image.get("Healthcheck"))["Test"]
    if test[0] == "CMD-SHELL":
        args = ["sh", "-c", test[1]]
    else:
        assert test[0] == "CMD", test
        args = list(test[1:])
    port = int(server[2].rsplit(":", 1)[1])
    if engine.kind == "podman" and port != PORT:  # the server was moved off a busy host 5006
        args = [a.replace(f":{PORT}/", f":{port}/") for a in args]
    proc = engine.exec(cid, *args, check=False)
    assert proc.returncode == 0, proc.stdout + proc.stderr

"""``python -m study SCENARIO.yaml --out DIR``: a study from a scenario file (docs/study.md).

Writes ``report.html`` (self-contained), ``summary.json`` (the numbers), ``maps.nc`` (the maps,
NetCDF), ``scenario.yaml`` (the scenario as run) and ``study.py`` (a script that reproduces the
numbers through core alone). A ``vary`` block in the file, or ``--vary d=5,10,15``, runs the
variants (on ``--workers`` processes, or a Dask cluster with ``--scheduler``) and writes one
comparison report. A refused file exits with status 2 and the reason.
"""

from __future__ import annotations

import argparse
import datetime
import sys
from pathlib import Path

from app.state import scenario_file as sf

EPILOG = "Example: python -m study app/state/presets/paper/05-fig-5.yaml --out fig5 --vary d=5,10,15,30"


def parser():
    p = argparse.ArgumentParser(prog="python -m study", description=__doc__.split("\n\n")[0],
                                epilog=EPILOG)
    p.add_argument("scenario", help="the scenario file (YAML, docs/study.md)")
    p.add_argument("--out", required=True, help="folder to write (refused if not empty, unless --force)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override an input (as a link writes it), e.g. --set Ph=150; repeatable")
    p.add_argument("--vary", action="append", default=[], metavar="KEY=V1,V2,…",
                   help="run the variants, e.g. --vary d=5,10,15,30 (with the file's vary block)")
    p.add_argument("--force", action="store_true", help="write into a folder that is not empty")
    p.add_argument("--workers", type=int, default=2, help="worker processes for variants (default 2)")
    p.add_argument("--scheduler", default=None, help="run variants on this Dask scheduler (tcp://host:port)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    return p


def _pairs(items, option):
    out = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise sf.ScenarioFileError([f"{option} {item!r}: give KEY=VALUE"])
        out[key.strip()] = value
    return out


def overrides(sets, varies):
    """``--set`` and ``--vary`` as typed values (as a link reads them): (sets, vary)."""
    from app.state.url import link_value

    typed = {k: link_value(v, k) if k in sf.names() else v for k, v in _pairs(sets, "--set").items()}
    vary = {k: [link_value(x, k) if k in sf.names() else x for x in v.split(",")]
            for k, v in _pairs(varies, "--vary").items()}
    return typed, vary


def _out_folder(path, force):
    out = Path(path)
    if out.exists() and not out.is_dir():
        raise sf.ScenarioFileError([f"--out {out} is a file, not a folder"])
    if out.is_dir() and any(out.iterdir()) and not force:
        raise sf.ScenarioFileError([f"--out {out} is not empty: give --force to write into it"])
    out.mkdir(parents=True, exist_ok=True)
    return out


def main(argv=None):
    args = parser().parse_args(argv)
    try:
        loaded = sf.load(args.scenario)
        sets, vary = overrides(args.set, args.vary)
        loaded = sf.with_inputs(loaded, sets, vary)
        out = _out_folder(args.out, args.force)
    except sf.ScenarioFileError as exc:
        print(f"python -m study: {exc}", file=sys.stderr)
        return 2
    for note in loaded.notes:
        print(f"note: {note}", file=sys.stderr)
    title = loaded.header.get("title") or Path(args.scenario).stem
    written = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    if loaded.vary:
        return _batch(args, loaded, out, title, written)
    from app.report import results

    from . import batch, script

    c = results.compute(loaded.values, loaded.log)
    summary = results.summary(c)
    batch.write_run(out, c, summary, log=loaded.log, log_name=loaded.log_name, title=title,
                    written=written, header=loaded.header)
    (out / "study.py").write_text(script.text(loaded.values, title=title, project=sf.project_version()),
                                   encoding="utf-8")
    print(f"wrote {out}/: {batch.REPORT}, {batch.SUMMARY}, {batch.MAPS}, {batch.SCENARIO}, study.py")
    return 0


def _batch(args, loaded, out, title, written):
    from tqdm import tqdm

    from core.dask_backend import connect

    from . import batch

    try:
        runs = batch.variants(loaded.vary)
    except sf.ScenarioFileError as exc:
        print(f"python -m study: {exc}", file=sys.stderr)
        return 2
    client = None
    try:
        if args.scheduler:
            client = connect(args.scheduler)
        with tqdm(total=len(runs), desc="variants", unit="variant", disable=args.no_progress,
                  file=sys.stderr) as bar:
            batch.run_batch(out, loaded.inputs, loaded.vary, log=loaded.log,
                            workers=max(1, min(args.workers, len(runs))), client=client,
                            progress=bar, title=f"{title}: {len(runs)} variants", written=written)
    except sf.ScenarioFileError as exc:
        print(f"python -m study: {exc}", file=sys.stderr)
        return 2
    except (ValueError, OSError) as exc:
        print(f"python -m study: {exc}", file=sys.stderr)
        return 1
    finally:
        if client is not None:
            client.close()
    print(f"wrote {out}/: {batch.REPORT} (comparison of {len(runs)} variants), {batch.SUMMARY}, "
          f"{batch.MAPS}, {batch.SCENARIO}")
    return 0

"""A scenario file (spec §12): the page's inputs as a small YAML text, written and read back.

What the file holds is derived, not listed: the inputs a link carries (:func:`app.url.query`:
every input of every part whose value differs from its default, written without float noise,
and in a layered sea the inputs the seabed moves), keyed by the link's names. Above them a
header: the format's name and integer version, the project's version, the UTC time it was
written. Beside them, optionally, the uploaded calibration log (embedded when small, or a path
and its SHA-256) and a ``vary`` block (the command line's batch).

Reading a file checks it exactly as a link is checked (:func:`app.url.link_problem` on each
value as typed, then :func:`app.url.read_link` on a fresh scenario for the rules between values):
a refused value names the key, the value and the limit, and nothing of the file is applied.
The loader is YAML's safe one, so a tag that would build a Python object is refused. On the
served page (``where="page"``) a file never makes the server read a path; the command line
(``where="cli"``) resolves a log's path relative to the file.
"""

from __future__ import annotations

import datetime
import difflib
import hashlib
import json
import math
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path
from urllib.parse import parse_qsl

import param
import yaml

import core
from .scenario import Scenario, parameter
from .url import link_problem, link_value, names, query, read_link

#: The format's name, the file's first key.
FORMAT = "dipole-observability scenario"
#: This format's version. Version 1 was the link's own flat form (every input at the top level,
#: beside the header); version 2 keeps the inputs under ``inputs:``, so that the file's own keys
#: (``calibration_log``, ``vary``) can never be taken for an input. Version 1 is migrated.
VERSION = 2
#: Largest scenario file read (bytes): a scenario is a few hundred bytes; an embedded log of the
#: largest embedded size below fits with room to spare.
MAX_BYTES = 1_000_000
#: Largest calibration log embedded in a written file (bytes); a larger one is referenced by its
#: path and SHA-256 (the command line), or must be uploaded again (the page).
MAX_EMBEDDED_LOG = 256_000
#: Most variants a ``vary`` block may ask for.
MAX_VARIANTS = 1000
#: The file's own keys (not inputs).
HEADER = ("format", "version", "project", "written", "title")
TOP_KEYS = (*HEADER, "inputs", "calibration_log", "vary")


class ScenarioFileError(ValueError):
    """A scenario file that is refused: ``problems`` names each key and why; nothing applied."""

    def __init__(self, problems):
        self.problems = list(problems)
        super().__init__("Scenario file refused, nothing of it applied: " + "; ".join(self.problems))


@dataclass
class Loaded:
    """What a checked scenario file holds."""

    inputs: dict  # link name -> value, as given (every one accepted)
    values: dict  # every input's value once applied to a fresh scenario (defaults + inputs)
    log: bytes | None = None  # the calibration log's bytes (embedded, or read by the CLI)
    log_name: str = ""
    vary: dict = field(default_factory=dict)  # input -> list of values (the CLI's batch)
    notes: list = field(default_factory=list)  # migrated, another project version …
    header: dict = field(default_factory=dict)


def project_version():
    """The installed project's version (the pyproject's), or 'unknown'."""
    try:
        return metadata.version("dipole-observability")
    except metadata.PackageNotFoundError:
        return "unknown"


def link_inputs(scenario, tab=None):
    """The inputs a link of ``scenario`` carries (:func:`app.url.query`), as typed values: the
    file's ``inputs`` block."""
    return {k: link_value(v, k) for k, v in parse_qsl(query(scenario, tab).lstrip("?"))
            if k in set(names())}


def _log_block(log, log_name, log_path):
    if log is None:
        return None
    sha = hashlib.sha256(log).hexdigest()
    if len(log) <= MAX_EMBEDDED_LOG and log_path is None:
        return {"name": log_name or "calibration.csv", "sha256": sha,
                "embedded": log.decode("utf-8", "replace")}
    if log_path is None:
        raise ValueError(f"a calibration log of {len(log):,} bytes is over the "
                         f"{MAX_EMBEDDED_LOG:,} bytes embedded: give its path to reference it")
    return {"name": log_name or Path(log_path).name, "path": str(log_path), "sha256": sha}


def dumps(scenario, *, log=None, log_name="", log_path=None, vary=None, now=None, title=None,
          inputs=None):
    """The scenario file (text) of ``scenario`` (an :class:`app.state.scenario.Scenario`).

    ``log``: the uploaded calibration log's bytes (embedded up to :data:`MAX_EMBEDDED_LOG`);
    ``log_path``: reference it by this path (relative to the file) and its SHA-256 instead.
    ``vary``: a batch (input -> list of values). ``now``: the UTC time written (default now).
    ``title``: a name for the study (a preset's). ``inputs``: write these instead of the link's
    (a preset's own values, some at their defaults)."""
    now = now or datetime.datetime.now(datetime.timezone.utc)
    doc = {"format": FORMAT, "version": VERSION, "project": project_version(),
           "written": now.strftime("%Y-%m-%dT%H:%M:%SZ")}
    doc.update({"title": title} if title else {})
    doc["inputs"] = link_inputs(scenario) if inputs is None else dict(inputs)
    block = _log_block(log, log_name, log_path)
    if block:
        doc["calibration_log"] = block
    if vary:
        doc["vary"] = {k: list(v) for k, v in vary.items()}
    return yaml.safe_dump(doc, sort_keys=False, allow_unicode=True, width=100)


# -- reading
def _parse(text):
    if isinstance(text, bytes):
        if len(text) > MAX_BYTES:
            raise ScenarioFileError([f"the file has {len(text):,} bytes; a scenario file is at most "
                                     f"{MAX_BYTES:,} bytes"])
        try:
            text = text.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise ScenarioFileError([f"the file is not UTF-8 text (byte {exc.start})"]) from None
    if len(text.encode("utf-8")) > MAX_BYTES:
        raise ScenarioFileError([f"the file has over {MAX_BYTES:,} bytes; a scenario file is at "
                                 f"most {MAX_BYTES:,} bytes"])
    try:
        doc = yaml.safe_load(text)
    except yaml.constructor.ConstructorError as exc:
        line = exc.problem_mark.line + 1 if exc.problem_mark else "?"
        raise ScenarioFileError([f"line {line}: a YAML tag that would build an object is refused "
                                 f"(only plain values are read: {str(exc.problem)[:120]})"]) from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"line {mark.line + 1}, column {mark.column + 1}" if mark else "the file"
        what = getattr(exc, "problem", None) or str(exc)
        raise ScenarioFileError([f"malformed YAML at {where}: {str(what)[:120]}"]) from None
    if not isinstance(doc, dict):
        raise ScenarioFileError([f"a scenario file is a YAML mapping (format: …, version: …, "
                                 f"inputs: …); got {type(doc).__name__}"])
    return doc


def _nearest(key, known):
    near = difflib.get_close_matches(str(key), list(known), n=1, cutoff=0.5)
    return f" (did you mean {near[0]!r}?)" if near else ""


def _migrate(doc, notes):
    """A file of an older version, in this version's form (with a note); a newer one refused."""
    if doc.get("format") != FORMAT:
        raise ScenarioFileError([f"format: {str(doc.get('format'))[:60]!r} is not a scenario file's "
                                 f"(expected format: {FORMAT})"])
    version = doc.get("version")
    if isinstance(version, bool) or not isinstance(version, int):
        raise ScenarioFileError([f"version: {str(version)[:20]!r} must be a whole number "
                                 f"(this program writes {VERSION})"])
    if version > VERSION:
        raise ScenarioFileError([f"version: {version} is newer than this program reads (1 … "
                                 f"{VERSION}; project {project_version()}): update the program"])
    if version < 1:
        raise ScenarioFileError([f"version: {version} is not a version (1 … {VERSION})"])
    if version == 1:  # the link's flat form: inputs beside the header
        flat = {k: v for k, v in doc.items() if k not in TOP_KEYS}
        doc = {**{k: v for k, v in doc.items() if k in TOP_KEYS}, "inputs": flat, "version": 2}
        notes.append(f"Migrated from format version 1 (inputs at the top level) to {VERSION}.")
    return doc


def _header_notes(doc, notes):
    unknown = [k for k in doc if k not in TOP_KEYS]
    if unknown:
        raise ScenarioFileError([f"{str(k)[:40]!r} is not a key of a scenario file"
                                 f"{_nearest(k, TOP_KEYS)}" for k in unknown])
    project = doc.get("project")
    if project is not None and str(project) != project_version():
        notes.append(f"Written by project version {project}; this is {project_version()}.")


def _check_inputs(given):
    if given is None:
        return {}
    if not isinstance(given, dict):
        raise ScenarioFileError([f"inputs: must be a mapping of input: value; got "
                                 f"{type(given).__name__}"])
    known = names()
    problems = [f"{str(k)[:40]!r} is not an input{_nearest(k, known)}" for k in given
                if k not in known]
    problems += [p for p in (_problem(k, _plain(v)) for k, v in given.items() if k in known) if p]
    if problems:
        raise ScenarioFileError(problems)
    return {k: _plain(v) for k, v in given.items()}


def accepted(name):
    """What input ``name`` accepts, in words (its parameter's type)."""
    p = parameter(name)
    if isinstance(p, param.Selector):
        return "one of " + ", ".join(repr(o) for o in p.objects)
    if isinstance(p, param.Integer):
        return "a whole number"
    if isinstance(p, param.Number):
        return "a number"
    if isinstance(p, param.List):  # its label says what of: stations (x, y, z), zones, numbers
        return f"a list: {p.label}"
    return "text"


def _problem(name, value):
    """The link's refusal of ``value`` for ``name`` (:func:`app.url.link_problem`), saying what
    is accepted when the type is wrong."""
    problem = link_problem(name, value)
    if problem and "does not accept" in problem:
        problem += f": it takes {accepted(name)}"
    return problem


def _plain(value):
    """A YAML value as a link would give it: a list of tuples is a list of lists."""
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def exact_text(value):
    """A value as link text that reads back exactly (:func:`app.url.link_value`): a link rounds
    floats to 12 digits; a file keeps what it says (a preset's 2·√2 m/s is the default's)."""
    return value if isinstance(value, str) else json.dumps(value)


def applied(inputs, scenario=None):
    """``scenario`` (default a fresh one) with ``inputs`` read exactly as a link's
    (:func:`app.url.read_link`: all or nothing): (scenario, problems)."""
    scenario = Scenario() if scenario is None else scenario
    link = read_link(scenario, {k: [exact_text(v)] for k, v in inputs.items()})
    return scenario, link.problems


def _read_log(block, where, base):
    if block is None:
        return None, ""
    if not isinstance(block, dict):
        raise ScenarioFileError(["calibration_log: must be a mapping (name, sha256, and embedded "
                                 "or path)"])
    unknown = [k for k in block if k not in ("name", "sha256", "embedded", "path")]
    if unknown:
        raise ScenarioFileError([f"calibration_log: {str(k)[:40]!r} is not one of its keys"
                                 f"{_nearest(k, ('name', 'sha256', 'embedded', 'path'))}"
                                 for k in unknown])
    name = str(block.get("name", "calibration.csv"))[:200]
    if "embedded" in block:
        data = str(block["embedded"]).encode("utf-8")
    elif "path" in block:
        data = _log_from_path(str(block["path"]), block.get("sha256"), where, base)
    else:
        raise ScenarioFileError(["calibration_log: give the log embedded (embedded: …) or its "
                                 "path and sha256"])
    sha = block.get("sha256")
    if sha is not None and hashlib.sha256(data).hexdigest() != str(sha).lower():
        raise ScenarioFileError([f"calibration_log: its SHA-256 {hashlib.sha256(data).hexdigest()} "
                                 f"differs from the file's {str(sha)[:64]}: not the log the "
                                 "scenario was written with"])
    try:
        core.parse_attitude_csv(data)
    except ValueError as exc:
        raise ScenarioFileError([f"calibration_log: {exc}"]) from None
    return data, name


def _log_from_path(path, sha, where, base):
    if where != "cli":
        raise ScenarioFileError([f"calibration_log: path {path[:80]!r} refused: a file opened on "
                                 "the page never makes the server read a path; upload the log, or "
                                 "save the scenario with the log embedded"])
    if sha is None:
        raise ScenarioFileError([f"calibration_log: path {path[:80]!r} needs its sha256"])
    p = Path(path)
    p = p if p.is_absolute() else Path(base or ".") / p
    if not p.is_file():
        raise ScenarioFileError([f"calibration_log: {p} is missing (a path is relative to the "
                                 "scenario file)"])
    if p.stat().st_size > core.calibration.MAX_CSV_BYTES:
        raise ScenarioFileError([f"calibration_log: {p} is over {core.calibration.MAX_CSV_BYTES:,} bytes"])
    return p.read_bytes()


def _check_vary(vary):
    if vary is None:
        return {}
    if not isinstance(vary, dict):
        raise ScenarioFileError(["vary: must be a mapping of input: [values]"])
    problems = [f"vary: {str(k)[:40]!r} is not an input{_nearest(k, names())}" for k in vary
                if k not in names()]
    problems += [f"vary: {k} needs a list of values; got {str(v)[:40]!r}" for k, v in vary.items()
                 if k in names() and (not isinstance(v, list) or not v)]
    if problems:
        raise ScenarioFileError(problems)
    count = math.prod(len(v) for v in vary.values())
    if count > MAX_VARIANTS:
        raise ScenarioFileError([f"vary: {count:,} variants; at most {MAX_VARIANTS:,}"])
    problems = [p for k, vs in vary.items() for p in (_problem(k, _plain(v)) for v in vs) if p]
    if problems:
        raise ScenarioFileError([f"vary: {p}" for p in problems])
    return {k: [_plain(v) for v in vs] for k, vs in vary.items()}


def loads(text, *, where="page", base=None):
    """Check a scenario file's text (str or bytes) and return what it holds (:class:`Loaded`);
    :class:`ScenarioFileError` naming every problem otherwise, nothing applied anywhere.

    ``where``: ``"page"`` (a path is never read) or ``"cli"`` (a log's path is read, relative to
    ``base``, the scenario file's folder)."""
    notes = []
    doc = _migrate(_parse(text), notes)
    _header_notes(doc, notes)
    inputs = _check_inputs(doc.get("inputs"))
    vary = _check_vary(doc.get("vary"))
    log, log_name = _read_log(doc.get("calibration_log"), where, base)
    fresh, problems = applied(inputs)
    if problems:
        raise ScenarioFileError(list(problems.values()))
    return Loaded(inputs=inputs, values=fresh.values(), log=log, log_name=log_name, vary=vary,
                  notes=notes, header={k: doc.get(k) for k in HEADER})


def with_inputs(loaded, more=None, vary=None):
    """``loaded`` with the inputs ``more`` set otherwise and the batch ``vary`` added (the
    command line's ``--set`` and ``--vary``), checked as the file's own: a new :class:`Loaded`."""
    inputs = _check_inputs({**loaded.inputs, **(more or {})})
    vary = _check_vary({**loaded.vary, **(vary or {})})
    fresh, problems = applied(inputs)
    if problems:
        raise ScenarioFileError(list(problems.values()))
    return Loaded(inputs=inputs, values=fresh.values(), log=loaded.log, log_name=loaded.log_name,
                  vary=vary, notes=loaded.notes, header=loaded.header)


def load(path, **kw):
    """:func:`loads` of a file on disk, its log's path resolved relative to it (the command line)."""
    p = Path(path)
    if not p.is_file():
        raise ScenarioFileError([f"{path}: no such file"])
    if p.stat().st_size > MAX_BYTES:
        raise ScenarioFileError([f"{path} has {p.stat().st_size:,} bytes; a scenario file is at "
                                 f"most {MAX_BYTES:,} bytes"])
    return loads(p.read_bytes(), where="cli", base=p.parent, **kw)


def apply(scenario, loaded):
    """Set a checked file's values on the page's ``scenario`` at once: every input the file's
    or its default (a file is a whole scenario)."""
    changed = {k: v for k, v in loaded.values.items() if scenario.value(k) != v}
    scenario.update(changed, as_given=True)


def defaults_text():
    """The file of the defaults (nothing differs)."""
    return dumps(Scenario())


__all__ = ["FORMAT", "VERSION", "MAX_BYTES", "Loaded", "ScenarioFileError", "apply", "dumps",
           "load", "loads", "link_inputs", "defaults_text", "with_inputs"]

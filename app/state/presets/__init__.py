"""The presets as scenario files (spec §12): the paper's figures and the seeds' cases of the
shared scenario (``paper/``), and the Calibration tab's cases (``calibration/``).

Each file is a scenario file (:mod:`app.state.scenario_file`) with a ``title`` (the button's label)
and, as ``inputs``, the preset's values: every input it sets, some at their defaults (a preset
is whole: what one preset sets, another sets back). Files are read in their names' order.
"""

from __future__ import annotations

from pathlib import Path

from ..scenario_file import loads

#: The folder of the preset files.
FOLDER = Path(__file__).parent
#: The families of presets: folder name -> what they set.
FAMILIES = ("paper", "calibration")


def files(family):
    """The preset files of ``family`` (one of :data:`FAMILIES`), in order."""
    if family not in FAMILIES:
        raise ValueError(f"unknown preset family {family!r}; the families are {', '.join(FAMILIES)}")
    return sorted((FOLDER / family).glob("*.yaml"))


def presets(family):
    """The presets of ``family``: title -> the inputs it sets (name -> value), in order."""
    out = {}
    for path in files(family):
        loaded = loads(path.read_bytes(), where="page")
        out[loaded.header["title"]] = loaded.inputs
    return out

"""The presets as scenario files (spec §12): the paper's figures and the seeds' cases of the
shared scenario (``paper/``), and the Calibration tab's cases (``calibration/``).

Each file is a scenario file (:mod:`app.state.scenario_file`) with a ``title`` (the button's label)
and, as ``inputs``, the preset's values: every input it sets, some at their defaults (a preset
is whole: what one preset sets, another sets back). Files are read in their names' order. They
are read here with YAML's safe loader only, as the page's state is built (the scenario file's
checks need that state: tests/test_scenario_file.py checks every preset file with them).
"""

from __future__ import annotations

from pathlib import Path

import yaml

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
        doc = yaml.safe_load(path.read_text(encoding="utf-8"))
        out[doc["title"]] = {k: [list(v) for v in val] if k == "stations" else val
                             for k, val in doc["inputs"].items()}
    return out

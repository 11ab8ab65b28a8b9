"""The command-line tools, the only modules of :mod:`core` that import argparse, matplotlib or
tqdm (tests/test_layout.py checks it): :mod:`.sweep` (``python -m core.sweep``), :mod:`.track`
(``python -m core.track``), :mod:`.calibration` (``python -m core.calibration``) and
:mod:`.shape` (``python -m core.shape``). ``import core`` imports none of them.
"""

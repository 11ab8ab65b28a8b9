"""The command-line tools, the only modules of :mod:`core` that import argparse, matplotlib or
tqdm (tests/test_layout.py checks it): :mod:`.sweep` (``python -m core.sweep``), :mod:`.track`
(``python -m core.track``), :mod:`.calibration` (``python -m core.calibration``) and
:mod:`.shape` (``python -m core.shape``, its figures in :mod:`.shape_plots`) and :mod:`.design`
(``python -m core.design``). ``import core`` imports none of them.

They (and ``python -m paper``) parse with :class:`ArgumentParser`, which names an unknown
option before a missing required one.
"""

import argparse
import sys

__all__ = ["ArgumentParser", "figure", "save"]


class ArgumentParser(argparse.ArgumentParser):
    """argparse's parser that reports unrecognised arguments first.

    argparse checks that the required arguments are present before it looks at the ones it does
    not know, so ``python -m paper --bogus`` said "the following arguments are required: --out"
    and never named ``--bogus``. Here a first pass parses with every required argument optional:
    anything it does not recognise is an error of its own (same wording and status as argparse:
    "unrecognized arguments: …", exit 2, through :meth:`error`), before the normal parse.
    The usage and help texts are always formatted with the required arguments required (``-h``
    in the first pass printed ``[--out OUT]``, as if it were optional: issue 46, defect 6).
    """

    def __init__(self, *args, **kwargs):
        self.added = []  # every action add_argument made (before super(): it adds --help)
        super().__init__(*args, **kwargs)

    def add_argument(self, *args, **kwargs):
        action = super().add_argument(*args, **kwargs)
        self.added.append(action)
        return action

    def _as_declared(self, fmt):
        """``fmt()`` with every argument declared required marked so (the first pass of
        :meth:`parse_args` lifts it)."""
        lifted = [a for a in self.added if getattr(a, "declared_required", False) and not a.required]
        for action in lifted:
            action.required = True
        try:
            return fmt()
        finally:
            for action in lifted:
                action.required = False

    def format_usage(self):
        return self._as_declared(super().format_usage)

    def format_help(self):
        return self._as_declared(super().format_help)

    def parse_args(self, args=None, namespace=None):
        args = sys.argv[1:] if args is None else list(args)
        required = [a for a in self.added if a.required]
        for action in required:
            action.declared_required = True
            action.required = False
        try:
            _, extras = self.parse_known_args(args)
        finally:
            for action in required:
                action.required = True
        if extras:
            self.error(f"unrecognized arguments: {' '.join(extras)}")
        return super().parse_args(args, namespace)


def figure(*args, **kwargs):
    """``matplotlib.pyplot.subplots(*args, **kwargs)`` on the Agg backend (matplotlib is imported
    here, only when a tool draws)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt.subplots(*args, **kwargs)


def save(fig, path, **kwargs):
    """Lay out, write and close a :func:`figure`."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    fig.savefig(path, **kwargs)
    plt.close(fig)

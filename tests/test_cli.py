"""What every command line shares (issue 25): an unknown option is named as such."""

import importlib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: module whose main(argv) is ``python -m NAME`` -> NAME
MAINS = {"core.cli.sweep": "core.sweep", "core.cli.track": "core.track",
         "core.cli.calibration": "core.calibration", "core.cli.shape": "core.shape",
         "paper.cli": "paper"}


def _status(module, argv):
    """The exit status of ``main(argv)``, which returns it or exits with it."""
    main = importlib.import_module(module).main
    try:
        code = main(argv)
    except SystemExit as exc:
        code = exc.code
    return code


@pytest.mark.parametrize("module", sorted(MAINS))
@pytest.mark.parametrize("argv", [["--bogus"], ["--bogus", "1"], ["data.csv", "--bogus"]])
def test_an_unknown_option_is_named_before_missing_required_ones(module, argv, capsys):
    # argparse checks required arguments first: `python -m paper --bogus` said
    # "the following arguments are required: --out" and never named --bogus.
    code = _status(module, argv)
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert code == 2
    assert last.startswith(f"python -m {MAINS[module]}: error: unrecognized arguments: ")
    assert "--bogus" in last and "required" not in last


@pytest.mark.parametrize("module", sorted(MAINS))
def test_missing_required_arguments_are_still_named(module, capsys):
    code = _status(module, [])
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert code == 2 and "the following arguments are required: " in last, last


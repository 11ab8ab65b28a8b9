"""What every command line shares (issue 25): an unknown option is named as such, and the
output folders of the README's commands are not left for ``git add``."""

import importlib
import re
import shutil
import subprocess
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


def _readme_outputs():
    """The folders the README's command lines write (``--out DIR``)."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    return sorted(set(re.findall(r"^\.venv/bin/python -m \S+ .*--out (\S+)", text, re.M)))


def test_the_readme_commands_outputs_are_ignored_by_git():
    # Running the README's commands left paper-figures/, sweep-d-z/, track-sim/ and shape-fig5/
    # as untracked folders for a `git add .` to commit.
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    outs = _readme_outputs()
    assert len(outs) >= 4, outs  # the reader finds the commands
    for out in outs:
        done = subprocess.run(["git", "check-ignore", "-q", "--no-index", f"{out}/x.csv"],
                              cwd=ROOT, check=False)
        assert done.returncode == 0, f"{out}/ (written by a README command) is not git-ignored"


@pytest.mark.parametrize("module", sorted(MAINS))
def test_help_is_plain_text_with_one_usage_line(module, capsys):
    # issue 40 (low): `python -m paper --help` showed the module's reStructuredText (``…``,
    # :mod:) and a second usage line of its own, shorter than argparse's
    code = _status(module, ["--help"])
    out = capsys.readouterr().out
    assert code == 0
    assert "``" not in out and not re.search(r":(mod|func|class|data):`", out), out
    assert len(re.findall(r"(?im)^\s*(usage|command line):", out)) == 1, out
    assert out.startswith(f"usage: python -m {MAINS[module]} "), out


#: The options each command declares required (their add_argument calls).
REQUIRED = {"core.cli.sweep": ["--x", "--y", "--out"], "core.cli.track": ["--case", "--out"],
            "core.cli.calibration": ["--be"], "core.cli.shape": ["--case", "--out"],
            "paper.cli": ["--out"]}


@pytest.mark.parametrize("module", sorted(MAINS))
def test_help_shows_required_options_as_required(module, capsys):
    # issue 46, defect 6: `python -m paper --help` showed `[--out OUT]` (optional) while its error
    # said "--out is required": the help was printed during the first pass, which lifts
    # `required` to find unknown options first. Every required option must appear bare (not in
    # brackets) in the help's usage, as in the usage printed with the error (the commands
    # whose error is one line print none).
    code = _status(module, ["--help"])
    usage = capsys.readouterr().out.split("\n\n")[0]
    assert code == 0
    for opt in REQUIRED[module]:
        assert f"[{opt}" not in usage, usage
        assert re.search(rf"(^|\s){re.escape(opt)}\s", usage), usage
    _status(module, [])
    err = capsys.readouterr().err
    if err.startswith("usage:"):  # the commands whose error prints argparse's usage first
        assert " ".join(err.rsplit("\n", 2)[0].split()) == " ".join(usage.split())

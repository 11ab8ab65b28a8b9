"""docs/ describes the present: no diary in it (history goes to CHANGELOG.md)."""

import re

import pytest

from support import ROOT

DOCS = sorted((ROOT / "docs").rglob("*.md")) + [ROOT / "README.md"]
#: What dates a text to when it was written: a diary's words, a calendar date, a commit hash (7
#: to 40 hex digits with at least one letter and one digit, so that numbers and words pass).
DIARY = {
    "today": re.compile(r"\btoday('s)?\b", re.I),
    "this session": re.compile(r"\bthis session\b", re.I),
    "a numbered session": re.compile(r"\b(session \d+|(first|second|third|fourth|fifth|sixth|seventh|"
                                     r"eighth|ninth|tenth|eleventh|twelfth|\d+(st|nd|rd|th)) session)\b", re.I),
    "a date": re.compile(r"\b20\d\d-\d\d(-\d\d)?\b"),
    "a commit hash": re.compile(r"(?<![#\w.-])(?=[0-9a-f]*[a-f])(?=[0-9a-f]*\d)[0-9a-f]{7,40}\b"),
}


@pytest.mark.parametrize("path", DOCS, ids=lambda p: str(p.relative_to(ROOT)))
def test_the_docs_keep_no_diary(path):
    found = [f"{path.name}:{n}: {what}: {m.group(0)!r}"
             for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
             for what, pattern in DIARY.items() for m in pattern.finditer(line)]
    assert found == []


@pytest.mark.parametrize("text, what", [
    ("measured today on", "today"), ("in this session", "this session"),
    ("(eighth session, main at", "a numbered session"), ("Session 2: lockstep", "a numbered session"),
    ("quiet machine, 2026-12-03", "a date"), ("main at ae16168", "a commit hash"),
    ("the previous kernel, 3dda9fa, gave", "a commit hash"),
])
def test_the_diary_check_finds_what_it_looks_for(text, what):
    assert DIARY[what].search(text)


@pytest.mark.parametrize("text", ["1.000000000000", "−15.81505528794", "7.2e-17 / 1.5e-51",
                                  "colour #1f77b4", "a decade of 2000 points", "deadbeef"])
def test_the_diary_check_passes_numbers(text):
    assert not any(p.search(text) for p in DIARY.values())


def test_the_changelog_has_an_unreleased_heading_at_the_top():
    headings = [line for line in (ROOT / "CHANGELOG.md").read_text(encoding="utf-8").splitlines()
                if line.startswith("## ")]
    assert headings[0] == "## Unreleased"

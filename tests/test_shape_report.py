"""The report's seed 003 section (paper/shape.py): a smoke test on few runs (2 per figure case,
1 per table row), checking the section's parts, not its numbers."""

import re

import numpy as np
import pytest

from paper import shape as ps


@pytest.fixture(scope="module")
def nums():
    return ps.numbers(fig_runs=2, table_runs=1)


def test_section_has_its_parts(nums):
    text = ps.section(nums)
    for heading in ("## Seed 003: locating and sizing an extended magnetic target",
                    "### Figs. 4 and 5 (2 Monte-Carlo passes each",
                    "### Tables 1–5 (our rows; 1 passes per row, lagged window n = 5",
                    "### What the bound says"):
        assert heading in text, heading
    assert "**Reproduced.**" in text and "**Assumed where the text is lost.**" in text
    # every table row of every case appears, with its verdicts
    for key, t in nums["tables"].items():
        for r in t["rows"]:
            assert f"| {key[-1]} | {r['label']} |" in text, r["label"]
    # the bound's table: header and one row per closest approach, both reads, the verdict
    assert ("| closest approach (m) | centroid (m) | main scale, span read (m) | main scale, second "
            "moment (m) |") in text
    assert "point dipole: position (m) | sizable |" in text
    rows = re.findall(r"^\| (\d+\.\d\d) \|(?: [^|]+ \|){7} (yes|no) \|$", text, flags=re.M)
    assert [float(r[0]) for r in rows] == pytest.approx([round(c, 2) for c in ps.BOUND_CPA])
    assert [r[1] for r in rows] == ["yes"] * 5 + ["no"] * 2  # sizable to 15 m, not at 20 and 30
    # the spec's figures: reproduced by the second-moment read with the axis along body x
    assert "are reproduced** by the second-moment read with the cylinder's axis along body x" in text
    assert re.search(r"a point dipole's position to (\d+) µm", text)
    # the one-sample update beside the window, and the batch fit, for both figures
    for label in ("Fig. 4", "Fig. 5"):
        assert f"| {label} | window (lag 5) | NHUKF |" in text
        assert f"| {label} | one sample (comparison) | NHUKF |" in text
        assert f"| {label} | window (lag 5) | FIT |" in text
    assert "**Beyond the paper: the batch fit**" in text
    assert not re.search(r"\bnan\b", text, flags=re.I)  # a tie's scale prints as —


def test_numbers_run_each_case_with_its_own_update(nums):
    """Every case uses cases.py's lag (5), as the CLI does, the figures' comparison rows one
    sample; the bound has the point dipole."""
    assert nums["fig_runs"] == 2 and nums["table_runs"] == 1
    assert {r["lag"] for t in nums["tables"].values() for r in t["rows"]} == {5}
    assert {d["lag"] for d in nums["fig"].values()} == {5}
    assert {d["lag"] for d in nums["one_sample"].values()} == {0}
    b7 = next(r for r in nums["bound"] if abs(r["closest_approach_m"] - np.sqrt(50)) < 1e-6)
    assert 15e-6 < b7["point_position_m"] < 25e-6  # the spec's "~20 µm"

"""``python -m study`` (issue 48): a run writes its report, numbers, maps, scenario and script;
a batch's numbers are the single runs'; the script reproduces the numbers through core alone;
bad input is refused with a message and a non-zero exit."""

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from app.tabs.maps.compute import READS, Snapshot, compute
from app.state.scenario import Scenario
from app.report import results
from study import batch, cli, script
from app.state import scenario_file as sf

SERIAL = "it runs the study in processes of its own (a pool of two, fresh interpreters)"
ROOT = Path(__file__).parents[1]

#: A small study: every tab computed, cheaply (40² maps, a short track, one pass).
SMALL = dict(resolution=40, track_runs=2, track_duration=60.0, track_filter="ekf", shape_runs=1,
             cal_iterations=50, measure="CRLB position error (m)", threshold=50.0)


def _file(tmp_path, **more):
    s = Scenario()
    s.update({**SMALL, **more})
    path = tmp_path / "study.yaml"
    path.write_text(sf.dumps(s, title="small"), encoding="utf-8")
    return path


def _env():
    return dict(os.environ, PYTHONPATH=str(ROOT))


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """One study run by the command line, in a process of its own: (folder, scenario values)."""
    tmp = tmp_path_factory.mktemp("study")
    path = _file(tmp)
    out = tmp / "out"
    done = subprocess.run([sys.executable, "-m", "study", str(path), "--out", str(out)],
                          capture_output=True, text=True, env=_env(), cwd=tmp, timeout=900)
    assert done.returncode == 0, done.stderr
    return out, sf.load(path).values


def test_a_run_writes_report_numbers_maps_scenario_and_script(run):
    out, _ = run
    assert sorted(p.name for p in out.iterdir()) == sorted(
        [batch.REPORT, batch.SUMMARY, batch.MAPS, batch.SCENARIO, "study.py"])
    html = (out / batch.REPORT).read_text(encoding="utf-8")
    # every script inline: no <script src=…>, no <link> (the browser test sees no request leave)
    assert re.findall(r"<script[^>]*\bsrc=", html) == [] and "<link" not in html
    assert (out / batch.REPORT).stat().st_size <= 5_000_000  # the target
    again = sf.load(out / batch.SCENARIO)
    assert again.values == run[1]  # the scenario as run reads back to the same inputs
    with xr.open_dataset(out / batch.MAPS, engine="h5netcdf") as ds:
        assert ds["A"].shape == (40, 40) and ds.attrs["resolution"] == 40


def test_the_summary_equals_an_in_process_computation_of_the_page(run):
    out, values = run
    summary = json.loads((out / batch.SUMMARY).read_text(encoding="utf-8"))
    # the page's maps, computed here, and their numbers by numpy in this test
    s = results.scenario_of(values)
    p = compute(Snapshot.of(s, READS))
    assert p.measure == "crlb_position"
    for key, res in zip("AB", (p.a, p.b)):
        seen = res.observable & np.isfinite(res.value)
        got = summary["maps"][key]
        assert got["share_within_threshold"] == float((seen & (res.value <= 50.0)).mean())
        assert got["share_unobservable"] == float(1 - res.observable.mean())
        if seen.any():
            # 1e-12 relative: the same numbers, another process (numba's cache may differ in the
            # last bits between a compiled and a loaded kernel: tests/test_dask.py)
            assert got["median_m"] == pytest.approx(np.median(res.value[seen]), rel=1e-12)
            assert got["p90_m"] == pytest.approx(np.percentile(res.value[seen], 90), rel=1e-12)
    assert summary["threshold_m"] == 50.0
    here = results.summary(results.compute(values))
    assert summary["best_spacing"]["best_d_m"] == pytest.approx(here["best_spacing"]["best_d_m"], rel=1e-12)
    assert summary["track"]["trmse_final_m"] == pytest.approx(here["track"]["trmse_final_m"], rel=1e-9)
    assert summary["shape"]["sizable"] == here["shape"]["sizable"]
    assert [r["crlb"] for r in summary["calibration"]["coefficients"]] == pytest.approx(
        [r["crlb"] for r in here["calibration"]["coefficients"]], rel=1e-12)
    assert summary["warnings"] == here["warnings"]


def test_the_script_reproduces_the_numbers_in_a_fresh_process_with_core_alone(run):
    out, _ = run
    text = (out / "study.py").read_text(encoding="utf-8")
    assert "import app" not in text and "from app" not in text and "panel" not in text
    done = subprocess.run([sys.executable, str(out / "study.py")], capture_output=True, text=True,
                          env=_env(), cwd=out, timeout=600)
    assert done.returncode == 0, done.stderr
    printed = json.loads(done.stdout)
    expected = script.expected(json.loads((out / batch.SUMMARY).read_text(encoding="utf-8")))
    assert printed.keys() == expected.keys()
    # the same core calls on the same literals: equal up to the last bits of a kernel compiled
    # here or loaded from numba's cache (1e-12 relative, as above)
    _close(printed, expected)


def _close(a, b, rel=1e-12):
    if isinstance(a, dict):
        assert a.keys() == b.keys()
        return all(_close(a[k], b[k], rel) for k in a)
    if isinstance(a, float) and isinstance(b, float):
        assert a == pytest.approx(b, rel=rel)
        return True
    assert a == b
    return True


def test_a_batch_numbers_equal_the_single_runs_on_a_pool_of_two(tmp_path, capsys):
    path = _file(tmp_path)
    out = tmp_path / "batch"
    assert cli.main([str(path), "--out", str(out), "--vary", "d=10,40", "--workers", "2"]) == 0
    assert "variants" in capsys.readouterr().err  # the progress bar
    summaries = json.loads((out / batch.SUMMARY).read_text(encoding="utf-8"))
    assert [s["variant"] for s in summaries] == [{"d": 10}, {"d": 40}]
    for s in summaries:
        single = results.summary(results.compute(sf.with_inputs(sf.load(path), s["variant"]).values))
        for key in "AB":
            assert s["maps"][key]["share_within_threshold"] == single["maps"][key]["share_within_threshold"]
            _close(s["maps"][key]["median_m"], single["maps"][key]["median_m"])
    html = (out / batch.REPORT).read_text(encoding="utf-8")
    assert "d = 10" in html and "d = 40" in html and re.findall(r"<script[^>]*\bsrc=", html) == []
    assert "vary:" in (out / batch.SCENARIO).read_text(encoding="utf-8")
    with xr.open_dataset(out / batch.MAPS, group="variant_001", engine="h5netcdf") as ds:
        assert ds.attrs["d"] == 40


def test_set_overrides_an_input_and_a_refused_one_exits_with_the_message(tmp_path, capsys):
    path = _file(tmp_path)
    assert cli.main([str(path), "--out", str(tmp_path / "a"), "--set", "Ph=-3"]) == 2
    err = capsys.readouterr().err
    assert "Ph" in err and "-3" in err and "0 … 100000 A·m" in err
    assert not (tmp_path / "a").exists()  # nothing written
    loaded = sf.with_inputs(sf.load(path), *cli.overrides(["Ph=150"], []))
    assert loaded.values["Ph"] == 150 and loaded.inputs["resolution"] == 40


def test_a_non_empty_folder_is_refused_unless_force(tmp_path, capsys):
    path = _file(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("x")
    assert cli.main([str(path), "--out", str(out)]) == 2
    assert "is not empty: give --force" in capsys.readouterr().err
    assert cli.main([str(path), "--out", str(out), "--force", "--set", "d=25"]) == 0
    assert "d: 25" in (out / batch.SCENARIO).read_text(encoding="utf-8")


@pytest.mark.parametrize("text, says", [
    ("format: dipole-observability scenario\nversion: 9\n", "newer than this program reads"),
    ("inputs: [\n", "malformed YAML at line"),
    ("format: dipole-observability scenario\nversion: 2\ninputs: {Phh: 1}\n", "did you mean 'Ph'"),
])
def test_a_refused_file_exits_non_zero_with_the_message(tmp_path, capsys, text, says):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    assert cli.main([str(path), "--out", str(tmp_path / "o")]) == 2
    assert says in capsys.readouterr().err


def test_a_vary_over_an_unknown_input_or_too_many_variants_is_refused(tmp_path, capsys):
    path = _file(tmp_path)
    assert cli.main([str(path), "--out", str(tmp_path / "o"), "--vary", "dd=1,2"]) == 2
    assert "did you mean 'd'" in capsys.readouterr().err
    many = ",".join(str(10 + i) for i in range(1001))
    assert cli.main([str(path), "--out", str(tmp_path / "o"), "--vary", f"Ph={many}"]) == 2
    assert "1,001 variants; at most 1,000" in capsys.readouterr().err


def test_a_vary_block_in_the_file_runs_the_batch(tmp_path):
    s = Scenario()
    s.update(SMALL)
    path = tmp_path / "vary.yaml"
    path.write_text(sf.dumps(s, vary={"Ph": [60, 90]}), encoding="utf-8")
    out = tmp_path / "out"
    assert cli.main([str(path), "--out", str(out), "--workers", "1", "--no-progress"]) == 0
    summaries = json.loads((out / batch.SUMMARY).read_text(encoding="utf-8"))
    assert [s["variant"] for s in summaries] == [{"Ph": 60}, {"Ph": 90}]
    assert summaries[0]["maps"]["B"]["median_m"] != summaries[1]["maps"]["B"]["median_m"]

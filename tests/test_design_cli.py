"""``python -m core.design`` (issue 49 item 6): it writes the layout, the maps and the CSV, and
refuses each bad input with its message."""

import csv
import json
import subprocess
import sys

import numpy as np
import pytest

import core
from core.cli import design

COMMON = ["--region=-300:300:-300:300:9", "--maxfev", "20", "--threshold", "30"]


def test_the_command_writes_the_layout_the_maps_and_the_csv(tmp_path):
    out = tmp_path / "design"
    cmd = [sys.executable, "-m", "core.design", "--out", str(out), "--new", "2",
           "--fixed=-200,0,100", "--zone=-250,-250;-150,-250;-150,-100", "--min-spacing", "40",
           "--criterion", "area_crlb", "--count", "--n-max", "4", *COMMON]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=300, check=False)
    assert done.returncode == 0, done.stderr
    with open(out / "layout.csv") as fh:
        rows = list(csv.DictReader(fh))
    stations = np.array([[float(r[k]) for k in ("x_m", "y_m", "z_m")] for r in rows])
    assert [r["role"] for r in rows] == ["fixed", "new", "new"]
    np.testing.assert_array_equal(stations[0], [-200, 0, 100])
    # the same problem through the API gives the same layout, value and maps
    args = design.parser().parse_args(cmd[3:])
    problem = design.problem_of(args)
    expect = core.optimise_layout("free", 2, problem, maxfev=20)
    np.testing.assert_allclose(stations, expect.stations, rtol=1e-15)  # CSV's repr round trip
    info = json.loads((out / "design.json").read_text())
    assert info["value"] == expect.value and info["unit"] == "dimensionless"
    loss = core.station_loss(expect.stations, problem)
    np.testing.assert_allclose([float(r["coverage_without"]) for r in rows], loss.coverage_left,
                               rtol=1e-15)
    import xarray as xr

    with xr.open_dataset(out / "maps.nc", engine="h5netcdf") as ds:
        crlb = core.crlb_maps(problem.region, expect.stations, velocity=(2, 2), moments=(100, 20))
        np.testing.assert_array_equal(ds["crlb_position"].values, crlb.position)
        np.testing.assert_array_equal(ds["worst_loss"].values, loss.worst)
        assert ds["loss"].shape == (3, 9, 9) and ds["crlb_position"].attrs["units"] == "m"
    with open(out / "count.csv") as fh:
        count = list(csv.DictReader(fh))
    curve = core.station_count_curve(problem, n_max=4, maxfev=20)
    assert [int(r["n_stations"]) for r in count] == curve.n.tolist() == [2, 3, 4]
    np.testing.assert_allclose([float(r["area_crlb"]) for r in count], curve.value, rtol=1e-15)


@pytest.mark.parametrize("args,message", [
    (["--zone=0,0;10,10;10,0;0,10"], "forbidden zone 0 is self-intersecting: its edges 0 and 2 cross"),
    (["--zone=0,0;10,10"], "forbidden zone 0 has 2 vertices; a polygon needs at least 3"),
    (["--fixed=5,5,100", "--zone=0,0;10,0;10,10;0,10"],
     "fixed station 0 at (5, 5) m lies inside forbidden zone 0"),
    (["--fixed=5,5,50", "--depth-band", "80:120"],
     "fixed station 0 at depth 50 m is outside the allowed depth band [80, 120] m"),
    (["--fixed=5,5,100", "--fixed=10,5,100", "--min-spacing", "20"],
     "fixed stations 0 and 1 are 5 m apart: they already break the minimum spacing 20 m"),
    (["--fixed=5,5,100", "--new", "8"], "1 fixed + 8 new = 9 stations; at most MAX_STATIONS = 8"),
    (["--zone=-400,-400;400,-400;400,400;-400,400"],
     "the constraints leave room for 0 of the 2 new stations"),
])
def test_the_command_refuses_each_bad_input_with_its_message(tmp_path, capsys, args, message):
    out = tmp_path / "design"
    with pytest.raises(SystemExit) as exc:
        design.main(["--out", str(out), *COMMON, *args])
    err = capsys.readouterr().err
    assert exc.value.code == 2
    assert err.splitlines()[-1].startswith(f"{design.PROG}: error: {message}"), err
    assert "Traceback" not in err
    assert not out.exists()  # nothing written

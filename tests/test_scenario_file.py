"""The scenario file (issue 48, spec §12): written from the link's inputs, read back checked
exactly as a link, all or nothing; bad input of every kind refused with a clear message."""

import hashlib
import json
from pathlib import Path

import param
import pytest

from app.state.part import declared
from app.state.scenario import PART_OF, Scenario, parameter
from app.state.url import query
from app.state import scenario_file as sf
from app.state.presets import FAMILIES, presets

HEAD = f"format: {sf.FORMAT}\nversion: {sf.VERSION}\n"
LOG = (Path(__file__).parents[1] / "data" / "seed004_table1.csv").read_bytes()


def _inputs(s):
    return {n: s.value(n) for n in PART_OF}


def _other_value(name):
    """Values of input ``name`` other than its default, derived from its declaration: another
    choice, a number inside its soft and hard bounds, a list or text of its kind."""
    p = parameter(name)
    if isinstance(p, param.Selector):
        return [o for o in p.objects if o != p.default]
    if isinstance(p, param.List):  # of its item type: stations, zones (polygons), station numbers
        return [[[5.0, -7.5, 90.0]], [[0.0, 0.0, 100.0], [30.0, 10.0, 100.0], [60.0, 0.0, 110.0]],
                [[[0.0, 0.0], [50.0, 0.0], [0.0, 50.0]]], [2], [1, 3]]
    if isinstance(p, param.String):
        return ["0, 120, 240", "-20, 0", "90"]
    lo, hi = p.softbounds
    hard = declared(p).get("hard", (lo, hi, ""))
    cands = [p.default + f * (b - p.default) for b in (hi, lo) for f in (0.37, 0.5, 1.0)]
    cands = [c for c in cands if hard[0] <= c <= hard[1] and c != p.default]
    return [int(round(c)) for c in cands] if isinstance(p, param.Integer) else [float(f"{c:.4g}") for c in cands]


def _taken(name):
    """A scenario holding a non-default value of ``name`` that it accepts (no refusal)."""
    for value in _other_value(name):
        s = Scenario()
        s.update({name: value})
        if s.message.endswith("Kept the last good value.") or s.value(name) == parameter(name).default:
            continue
        return s
    raise AssertionError(f"no accepted non-default value for {name}")


@pytest.mark.parametrize("name", list(PART_OF))
def test_link_file_link_is_identical_for_every_input(name):
    s = _taken(name)
    link = query(s)
    assert name in link  # the value differs from its default: the link carries it
    loaded = sf.loads(sf.dumps(s))
    again, problems = sf.applied(loaded.inputs)
    assert problems == {}
    assert query(again) == link and _inputs(again) == _inputs(s)


def test_a_file_and_a_link_of_a_layered_sea_with_stations_are_equivalent():
    s = Scenario()
    s.apply_preset("Seed 001 sea trial")
    s.update(track_heading=33.0, cal_source="Designed manoeuvre", cal_headings="0, 45, 90", Ph=101.3)
    text = sf.dumps(s)
    assert "stations" in text and "sea_model: layered" in text
    again, _ = sf.applied(sf.loads(text).inputs)
    assert query(again) == query(s) and _inputs(again) == _inputs(s)


def test_the_header_says_format_version_project_and_utc_time():
    import yaml
    doc = yaml.safe_load(sf.dumps(Scenario()))
    assert doc["format"] == sf.FORMAT and doc["version"] == sf.VERSION
    assert doc["project"] == sf.project_version() and doc["written"].endswith("Z")
    assert doc["inputs"] == {}  # the defaults: nothing differs


def test_apply_sets_every_input_of_the_file_or_its_default_on_a_changed_page():
    page = Scenario()
    page.update(Ph=300.0, track_runs=9, shape_roll=10.0)
    written = Scenario()
    written.update(Pv=42.0, d=33.0)
    sf.apply(page, sf.loads(sf.dumps(written)))
    assert _inputs(page) == _inputs(written) and page.message == ""


# -- bad input: a clear message, nothing applied
def _refused(text, *, where="page", base=None):
    with pytest.raises(sf.ScenarioFileError) as err:
        sf.loads(text, where=where, base=base)
    return str(err.value)


def test_a_value_out_of_range_names_key_value_and_limit():
    msg = _refused(HEAD + "inputs:\n  Ph: -5\n  d: 20\n")
    assert "Ph" in msg and "-5" in msg and "0 … 100000 A·m" in msg and "nothing of it applied" in msg


def test_values_that_break_a_rule_together_are_refused_whole():
    msg = _refused(HEAD + "inputs:\n  sea_model: layered\n  sea_depth: 80\n  h: 100\n")
    assert "h:" in msg and "water column 0 … 80 m" in msg


def test_an_unknown_key_is_named_with_the_nearest_known_key():
    msg = _refused(HEAD + "inputs:\n  track_heding: 30\n")
    assert "'track_heding' is not an input" in msg and "did you mean 'track_heading'" in msg
    msg = _refused(HEAD + "input:\n  Ph: 3\n")
    assert "'input' is not a key" in msg and "did you mean 'inputs'" in msg


def test_a_wrong_type_is_refused():
    msg = _refused(HEAD + "inputs:\n  Ph: a lot\n")
    assert "Ph" in msg and "'a lot'" in msg
    assert "it takes a whole number" in _refused(HEAD + "inputs:\n  track_runs: 2.5\n")
    assert "one of 'bank'" in _refused(HEAD + "inputs:\n  track_filter: kalman\n")
    assert "must be a mapping" in _refused(HEAD + "inputs: [1, 2]\n")


def test_malformed_yaml_says_the_line():
    msg = _refused(HEAD + "inputs:\n  Ph: [1, 2\n  Pv: 3\n")
    assert "malformed YAML at line" in msg
    assert "line 5" in _refused(HEAD + "inputs:\n  Ph: 3\n Pv: 4\n")  # the line of " Pv"


def test_a_newer_version_is_refused_an_older_one_migrated_with_a_note():
    assert "newer than this program reads" in _refused(
        f"format: {sf.FORMAT}\nversion: {sf.VERSION + 1}\ninputs: {{}}\n")
    old = sf.loads(f"format: {sf.FORMAT}\nversion: 1\nPh: 55.5\nd: 40\n")
    assert old.inputs == {"Ph": 55.5, "d": 40} and old.values["Ph"] == 55.5
    assert any("Migrated from format version 1" in n for n in old.notes)
    assert "is not a scenario file's" in _refused("format: something else\nversion: 1\n")


def test_a_file_over_one_megabyte_is_refused():
    big = HEAD + "# " + "x" * sf.MAX_BYTES + "\n"
    assert "at most 1,000,000 bytes" in _refused(big)
    assert "at most 1,000,000 bytes" in _refused(big.encode())


def test_a_yaml_tag_that_builds_a_python_object_is_refused():
    msg = _refused(HEAD + "inputs:\n  Ph: !!python/object/apply:os.system ['echo hi']\n")
    assert "tag that would build an object is refused" in msg and "line 4" in msg


def test_an_embedded_log_is_kept_and_its_hash_checked():
    s = Scenario()
    s.update(cal_source="Uploaded CSV")
    loaded = sf.loads(sf.dumps(s, log=LOG, log_name="table1.csv"))
    assert loaded.log == LOG and loaded.log_name == "table1.csv"
    text = sf.dumps(s, log=LOG).replace(hashlib.sha256(LOG).hexdigest(), "0" * 64)
    assert "differs from the file's" in _refused(text)


@pytest.mark.parametrize("path", ["/etc/passwd", "../../x", "logs/table1.csv"])
def test_a_file_opened_on_the_page_never_reads_a_path(path):
    text = HEAD + f"calibration_log:\n  path: {path}\n  sha256: {'0' * 64}\n"
    msg = _refused(text, where="page")
    assert "never makes the server read a path" in msg and path in msg


def test_the_command_line_reads_a_log_relative_to_the_file_and_checks_it(tmp_path):
    (tmp_path / "logs").mkdir()
    (tmp_path / "logs" / "t1.csv").write_bytes(LOG)
    s = Scenario()
    s.update(cal_source="Uploaded CSV")
    text = sf.dumps(s, log=LOG, log_path="logs/t1.csv")
    (tmp_path / "study.yaml").write_text(text)
    assert sf.load(tmp_path / "study.yaml").log == LOG
    (tmp_path / "logs" / "t1.csv").write_bytes(LOG + b"1,2,3,0,0,0\n")
    assert "differs from the file's" in _refused(text, where="cli", base=tmp_path)
    (tmp_path / "logs" / "t1.csv").unlink()
    assert "is missing" in _refused(text, where="cli", base=tmp_path)


def test_a_vary_over_an_unknown_input_or_over_1000_variants_is_refused():
    assert "did you mean 'd'" in _refused(HEAD + "vary:\n  dd: [5, 10]\n")
    many = HEAD + "vary:\n  d: [" + ", ".join(str(5 + i) for i in range(40)) + "]\n  Ph: [" + \
        ", ".join(str(10 + i) for i in range(26)) + "]\n"
    assert "1,040 variants; at most 1,000" in _refused(many)
    assert "d:" in _refused(HEAD + "vary:\n  d: [5, -1]\n")


# -- presets: one place, files
BEFORE = json.loads((Path(__file__).parent / "data" / "presets_before_files.json").read_text())


@pytest.mark.parametrize("family", FAMILIES)
def test_each_preset_file_gives_exactly_the_preset_values_of_before(family):
    # tests/data/presets_before_files.json: the presets' values as app.state.scenario.PRESETS and
    # app.tabs.calibration.calibration.PRESETS held them before they moved into files (issue 48)
    assert presets(family) == BEFORE[family]


def test_a_preset_file_applied_to_a_fresh_scenario_is_the_preset_applied():
    for name, values in presets("paper").items():
        s, problems = sf.applied(values)
        ref = Scenario()
        ref.apply_preset(name)
        assert problems == {} and _inputs(s) == _inputs(ref), name


@pytest.mark.parametrize("family", FAMILIES)
def test_every_preset_file_is_checked_as_a_link_and_is_what_the_page_loads(family):
    from app.state import scenario as state
    from app.state.presets import files
    from app.tabs.calibration import calibration

    shown = {"paper": state.PRESETS, "calibration": calibration.PRESETS}[family]
    assert shown == presets(family) and len(shown) == len(files(family)) > 0
    for path in files(family):
        loaded = sf.loads(path.read_bytes(), where="page")  # refused, it would raise
        assert loaded.inputs == shown[loaded.header["title"]]

"""``python -m study --vary … --scheduler ADDRESS`` on a real Dask scheduler and two worker
processes (started by tests/test_dask.py's fixture): the batch's numbers equal the single runs'."""

import json
import time

from app.report import results
from study import batch, cli
from app.state import scenario_file as sf
from tests.test_dask import cluster  # noqa: F401  (the fixture: a scheduler and two workers)
from tests.test_study import _close, _file

SERIAL = "it runs a Dask scheduler and workers"


def test_a_batch_on_a_dask_scheduler_equals_the_single_runs(cluster, tmp_path, capsys):  # noqa: F811
    address, client = cluster
    client.get_task_stream()  # installs the scheduler's task-stream recorder
    start = time.time()
    path = _file(tmp_path)
    out = tmp_path / "batch"
    assert cli.main([str(path), "--out", str(out), "--vary", "d=10,40", "--scheduler", address]) == 0
    assert "variants" in capsys.readouterr().err  # the progress bar
    tasks = [t for t in client.get_task_stream(start=start) if t["key"].startswith("_evaluate-")]
    assert len(tasks) == 2  # the two variants ran on the cluster
    summaries = json.loads((out / batch.SUMMARY).read_text(encoding="utf-8"))
    for s in summaries:
        single = results.summary(results.compute(sf.with_inputs(sf.load(path), s["variant"]).values))
        for key in "AB":
            assert s["maps"][key]["share_within_threshold"] == single["maps"][key]["share_within_threshold"]
            _close(s["maps"][key]["median_m"], single["maps"][key]["median_m"])

"""A study's runs: one scenario, or its variants (a ``vary`` block), written to a folder.

Each variant is the scenario with some inputs set otherwise; every variant is checked (as a
link, :mod:`app.state.scenario_file`) before any runs. Variants run in worker processes or on a
Dask cluster, through core's one way of running independent evaluations
(:func:`core.dask_backend.run_calls`, as ``core.sweep`` does), with a progress bar.
"""

from __future__ import annotations

import itertools
import json
from pathlib import Path

from app.report import html as report
from app.report import results
from app.state.scenario_file import MAX_VARIANTS, ScenarioFileError, applied, dumps
from app.tabs.maps.downloads import to_dataset

#: The files of one run, in its folder.
REPORT, SUMMARY, MAPS, SCENARIO = "report.html", "summary.json", "maps.nc", "scenario.yaml"


def variants(vary):
    """Every combination of a ``vary`` block (input -> list of values): [{input: value}, …]."""
    if not vary:
        return [{}]
    keys = list(vary)
    combos = list(itertools.product(*(vary[k] for k in keys)))
    if len(combos) > MAX_VARIANTS:
        raise ScenarioFileError([f"vary: {len(combos):,} variants; at most {MAX_VARIANTS:,}"])
    return [dict(zip(keys, c)) for c in combos]


def checked_variants(inputs, vary):
    """The inputs of every variant, each checked with the rest as a link is; refused whole."""
    out, problems = [], []
    for v in variants(vary):
        given = {**inputs, **v}
        scenario, why = applied(given)
        problems += [f"variant {json.dumps(v, ensure_ascii=False)}: {p}" for p in why.values()]
        out.append((v, scenario.values()))
    if problems:
        raise ScenarioFileError(problems)
    return out


def run_one(values, log=None):
    """Compute one variant (in a worker): (its summary, its maps' Panels)."""
    c = results.compute(values, log)
    return results.summary(c), c.maps, c.crlb


def maps_dataset(maps, crlb, values):
    """The maps as NetCDF data: the page's export (app.tabs.maps.downloads.to_dataset) of the maps shown,
    and of the CRLB position error when another measure is shown (``crlb_`` variables)."""
    params = {k: v for k, v in values.items() if isinstance(v, (int, float, str))}
    ds = to_dataset(maps, params)
    if crlb is not maps:
        extra = to_dataset(crlb, {})
        ds = ds.merge(extra[["A", "B", "difference"]].rename(
            {"A": "crlb_A", "B": "crlb_B", "difference": "crlb_difference"}))
    return ds


def write_run(folder, c, summary, *, log=None, log_name="", title="Observability study",
              written="", header=None):
    """Write one run's files to ``folder``: report, summary JSON, maps NetCDF, scenario as run."""
    folder = Path(folder)
    scenario = results.scenario_of(c.values)
    (folder / SCENARIO).write_text(dumps(scenario, log=log, log_name=log_name, title=title),
                                   encoding="utf-8")
    (folder / SUMMARY).write_text(json.dumps(summary, indent=1, ensure_ascii=False) + "\n",
                                  encoding="utf-8")
    maps_dataset(c.maps, c.crlb, c.values).to_netcdf(folder / MAPS, engine="h5netcdf")
    report.write(folder / REPORT, c, summary, title=title, written=written, header=header)


def run_batch(folder, inputs, vary, *, log=None, workers=1, client=None, progress=None, **kw):
    """Run every variant (:func:`checked_variants`) and write the comparison to ``folder``: a
    summary JSON of every variant, the maps of each (NetCDF, one group per variant), the
    comparison report and the scenario with its ``vary`` block. Returns the summaries."""
    from core.dask_backend import run_calls

    folder = Path(folder)
    runs = checked_variants(inputs, vary)
    calls = [(values, log) for _, values in runs]
    out = [None] * len(runs)
    for i, res in run_calls(run_one, calls, workers=workers, client=client):
        out[i] = res
        if progress is not None:
            progress.update(1)
    summaries = [dict(variant=v, **s) for (v, _), (s, _, _) in zip(runs, out)]
    scenario, _ = applied(inputs)
    (folder / SCENARIO).write_text(dumps(scenario, log=log, vary=vary, title=kw.get("title")),
                                   encoding="utf-8")
    (folder / SUMMARY).write_text(json.dumps(summaries, indent=1, ensure_ascii=False) + "\n",
                                  encoding="utf-8")
    for i, ((v, values), (_, maps, crlb)) in enumerate(zip(runs, out)):
        mode = "w" if i == 0 else "a"
        maps_dataset(maps, crlb, values).to_netcdf(folder / MAPS, mode=mode, group=f"variant_{i:03d}",
                                                   engine="h5netcdf")
    report.write_comparison(folder / REPORT, runs, out, **kw)
    return summaries


__all__ = ["checked_variants", "maps_dataset", "run_batch", "run_one", "variants", "write_run"]

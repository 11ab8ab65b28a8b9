"""``python -m core.track``: Monte-Carlo tracking on seed 001's cases, from the command line.

``python -m core.track --case seed001-sim|seed001-trial [--sensor E|B|G|BG]
[--filter ekf|puekf|bank] [--runs N] [--seed S] [--n-pu N] [--workers W] [--scheduler ADDR]
[--truth-noise] --out DIR`` runs :func:`core.tracking.montecarlo.monte_carlo` (``--sensor`` other
than E: :func:`core.tracking.cases.case_for_sensor`) and writes ``DIR/trmse.csv`` (``step,
time_s, trmse_m, pcrlb_m``; TRMSE_k of seed 001 eq. (18)), ``DIR/summary.json`` (what its
flags mean: docs/tracking.md, *What the summary flags*) and ``DIR/trmse.png``.
"""

from __future__ import annotations

import json
import os
import sys

import numpy as np
from tqdm import tqdm

from ..model.sensors import KINDS
from ..tracking.cases import CASES, case_for_sensor
from ..tracking.montecarlo import DEFAULT_N_PU, FILTERS, monte_carlo
from . import ArgumentParser

__all__ = ["main", "write_outputs"]


def write_outputs(result, out):
    """Write trmse.csv, summary.json and trmse.png of a :class:`MonteCarloResult` into ``out``."""
    os.makedirs(out, exist_ok=True)
    k = np.arange(result.time_s.size)
    with open(os.path.join(out, "trmse.csv"), "w") as fh:
        fh.write("step,time_s,trmse_m,pcrlb_m\n")
        for row in zip(k, result.time_s, result.trmse_m, result.pcrlb_m):
            fh.write(f"{row[0]:d},{row[1]:.6g},{row[2]:.9g},{row[3]:.9g}\n")
    with open(os.path.join(out, "summary.json"), "w") as fh:
        json.dump(result.summary, fh, indent=2, ensure_ascii=False)
    _plot(result, os.path.join(out, "trmse.png"))


def diverged_text(s):
    """The diverged share of a summary ("20 %"), or why it is not judged."""
    return "not judged" if s["diverged"] is None else f"{100 * s['diverged']:.0f} %"


def nees_warning(s):
    """A WARNING line when the mean NEES is outside its consistent band, else ''."""
    if s.get("nees_consistent") is not False:
        return ""
    lo, hi = s["nees_band"]
    side = ("overconfident: its covariance claims far less error than it makes"
            if s["nees"] > hi else "underconfident: its covariance is larger than its errors")
    return (f"WARNING: mean NEES {s['nees']:.3g} is outside {lo:.3g} … {hi:.3g}, the "
            f"{s['nees_level']:.0%} band of a consistent {s['nees_dof']}-state filter over "
            f"{s['runs']} runs: the filter is {side}; do not quote its σ.")


def _plot(result, path):
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7, 4.2), dpi=110)
    ax = fig.add_subplot()
    s = result.summary
    ax.semilogy(result.time_s, result.trmse_m, label=f"TRMSE ({s['filter']}, {s['runs']} runs)")
    ax.semilogy(result.time_s, np.where(np.isfinite(result.pcrlb_m), result.pcrlb_m, np.nan),
                "k--", label="PCRLB position σ")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("position error (m)")
    ax.set_title(f"{s['case']}: diverged {diverged_text(s)}")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path)


class _Bar:
    """The tqdm bar handed to :func:`monte_carlo`, made at its first ``reset(total=)``: a tqdm
    made before the total is known draws a stray "0it" bar first."""

    def __init__(self, desc):
        self.desc, self.bar = desc, None

    def reset(self, total=None):
        if self.bar is None:
            self.bar = tqdm(total=total, desc=self.desc, file=sys.stderr)
        else:
            self.bar.reset(total=total)

    def update(self, n=1):
        if self.bar is not None:
            self.bar.update(n)

    def close(self):
        if self.bar is not None:
            self.bar.close()


def main(argv=None):
    """Command line (``argv``: the arguments, default ``sys.argv[1:]``): see the module notes."""
    ap = ArgumentParser(prog="python -m core.track",
                                 description="Monte-Carlo tracking on seed 001's cases: TRMSE vs PCRLB")
    ap.add_argument("--case", required=True, choices=sorted(CASES))
    ap.add_argument("--filter", default="bank", choices=FILTERS)
    ap.add_argument("--sensor", default="E", choices=list(KINDS),
                    help="what the stations measure: E electric (seed 001), B magnetometer, "
                         "G gradiometer, BG both (the case's target then carries a magnetic "
                         "moment, core.tracking.cases.case_for_sensor)")
    ap.add_argument("--runs", type=int, default=100)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--n-pu", type=int, default=None, help=f"progressive sub-updates (default {DEFAULT_N_PU} for puekf, 1 otherwise)")
    ap.add_argument("--workers", type=int, default=None,
                    help="processes (default: both cores from 200 runs on, else this process: "
                         "spawned workers pay seconds of start-up for imports and compiled kernels)")
    ap.add_argument("--scheduler", default=None, help="Dask scheduler address, e.g. tcp://127.0.0.1:8786")
    ap.add_argument("--truth-noise", action="store_true", help="sample true tracks from the DWNA model")
    ap.add_argument("--out", required=True)
    a = ap.parse_args(argv)
    if a.workers is None:
        a.workers = min(2, os.cpu_count() or 1) if a.runs >= 200 else 1
    try:
        res = monte_carlo(case_for_sensor(a.case, a.sensor), filter=a.filter, runs=a.runs, seed=a.seed, n_pu=a.n_pu,
                          workers=a.workers, scheduler=a.scheduler, truth_noise=a.truth_noise,
                          progress=_Bar(f"{a.case} {a.filter}"))
    except ValueError as exc:
        ap.error(str(exc))
    write_outputs(res, a.out)
    s = res.summary
    # mean NEES to 3 digits beside its consistent value, as the Track tab says it
    nees = ("mean NEES —" if s["nees"] is None
            else f"mean NEES {s['nees']:.3g} ({s['nees_dof']} states: {s['nees_dof']} if consistent)")
    print(f"{s['case']} {s['filter']}: {s['runs']} runs in {s['elapsed_s']} s, diverged "
          f"{diverged_text(s)}, final TRMSE {s['trmse_final_m']:.3g} m vs PCRLB "
          f"{s['pcrlb_final_m']:.3g} m, {nees}; wrote {a.out}")
    if s["diverged"] is None:
        print(f"Divergence {s['diverged_rule']}.")
    warning = nees_warning(s)
    if warning:
        print(warning)
    return 0


if __name__ == "__main__":
    sys.exit(main())

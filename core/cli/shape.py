"""``python -m core.shape --case CASE [--runs N] [--seed S] [--lag N] --out DIR``.

Runs a case of seed 003 (:data:`core.shape.cases.CASES`) with ``runs`` Monte-Carlo passes and
writes into DIR:

- ``summary.json``: the case's truth and, per row of the case (Tables have several), per filter
  ("euler", "ukf", "nhukf") ``centroid_error_m``, ``peak_error_m``, ``main_scale_m``,
  ``main_scale_error_m``, ``axis_error_deg``, ``kind``, ``nees`` (medians over runs; the
  metrics of :mod:`core.shape.experiment`); the top-level ``filters`` and ``truth`` are the
  first row's;
- ``errors_rowI.png``: position error along the pass for each filter (run 0), outliers marked;
- ``shape_rowI.png``: run 0's final dipoles and PCA axes over the target's outline, plan (x–y)
  and side (x–z) views.

Every bad input prints one line ``python -m core.shape: error: …`` and exits with status 2.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from dataclasses import replace

import numpy as np

from ..shape.cases import CASES, case_rows
from ..shape.experiment import run_case

PROG = "python -m core.shape"


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, status 2 (argparse's default adds the usage text)
        print(f"{PROG}: error: {message}", file=sys.stderr)
        sys.exit(2)


def _int(lo, what):
    def conv(s):
        try:
            v = int(s)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be an integer ≥ {lo} ({what}); got {s!r}") from None
        if v < lo:
            raise argparse.ArgumentTypeError(f"must be an integer ≥ {lo} ({what}); got {s!r}")
        return v
    return conv


def _parser():
    p = _Parser(prog=PROG, description=__doc__.split("\n")[0])
    p.add_argument("--case", required=True, choices=list(CASES), metavar="CASE",
                   help="one of " + ", ".join(CASES))
    p.add_argument("--runs", type=_int(1, "Monte-Carlo passes"), default=1)
    p.add_argument("--seed", type=_int(0, "random seed"), default=0)
    p.add_argument("--lag", type=_int(0, "seed 003's window lag n; 0 = one-sample update"), default=0)
    p.add_argument("--out", required=True, help="output folder (created if missing)")
    return p


def _check_out(out):
    if os.path.exists(out) and not os.path.isdir(out):
        raise ValueError(f"--out must be a folder; {out!r} is a file")
    try:
        os.makedirs(out, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"--out {out!r} cannot be created: {exc.strerror}") from None
    if not os.access(out, os.W_OK):
        raise ValueError(f"--out {out!r} is not writable")


def _plot_errors(res, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    for name, style in (("euler", ":"), ("ukf", "-"), ("nhukf", "--")):
        if name in res.errors:
            ax.semilogy(res.platform_x, res.errors[name][0], style, label=name.upper())
    for k in res.outlier_samples:
        ax.axvline(res.platform_x[k], color="r", alpha=0.4, lw=1)
    if res.outlier_samples:
        ax.plot([], [], color="r", alpha=0.4, label="outlier")
    ax.set_xlabel("platform x (m)")
    ax.set_ylabel("position error (m)")
    ax.set_title(f"{res.case.name}: error along the pass (run 0)")
    ax.legend()
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def _plot_shape(res, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(9, 4.2))
    t = res.case.target
    for ax, (i, j, lab) in zip(axes, ((0, 1, "plan: x–y"), (0, 2, "side: x–z"))):
        for ln in t.outline():
            ax.plot(ln[:, i], ln[:, j], color="0.6", lw=1)
        for name, mk in (("ukf", "o"), ("nhukf", "^")):
            if name not in res.dipoles:
                continue
            d = res.dipoles[name][0]
            ax.plot(d[:, i], d[:, j], mk, label=f"{name.upper()} dipoles")
            c, V, w = res.final[name]["centroid"][0], res.final[name]["axes"][0], res.final[name]["eigenvalues"][0]
            for q in range(2):
                half = np.sqrt(max(w[q], 0.0)) * 2 * V[:, q]
                ax.plot([c[i] - half[i], c[i] + half[i]], [c[j] - half[j], c[j] + half[j]],
                        "-" if q == 0 else "--", lw=1.5)
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("xyz"[i] + " (m)")
        ax.set_ylabel("xyz"[j] + " (m)" + (" (down)" if j == 2 else ""))
        ax.set_title(lab)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle(f"{res.case.name}: dipoles and PCA axes (±2√λ) over the outline")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def run(case, runs=1, seed=0, lag=0, out=None, plots=True):
    """Run a case; write summary.json (and plots) into ``out`` if given. Returns the summary."""
    desc, rows = case_rows(case)
    results = []
    for row in rows:
        if lag:
            row = replace(row, lag=lag)
        results.append(run_case(row, runs=runs, seed=seed))
    summary = {"case": case, "description": desc, "runs": runs, "seed": seed, "lag": lag,
               "truth": results[0].summary["case"], "filters": results[0].summary["filters"],
               "rows": [{"label": r.case.name, "truth": r.summary["case"], "filters": r.summary["filters"],
                         "outlier_samples": r.outlier_samples} for r in results]}
    if out is not None:
        with open(os.path.join(out, "summary.json"), "w", encoding="utf-8") as fh:
            json.dump(summary, fh, indent=1)
        if plots:
            for i, r in enumerate(results):
                _plot_errors(r, os.path.join(out, f"errors_row{i}.png"))
                _plot_shape(r, os.path.join(out, f"shape_row{i}.png"))
    return summary


def main(argv=None):
    a = _parser().parse_args(sys.argv[1:] if argv is None else argv)
    try:
        _check_out(a.out)
    except ValueError as exc:
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        sys.exit(2)
    s = run(a.case, runs=a.runs, seed=a.seed, lag=a.lag, out=a.out)
    for row in s["rows"]:
        f = row["filters"]
        print(f"{row['label']}: " + "; ".join(
            f"{n} centroid {v['centroid_error_m']:.3f} m" + (
                f", scale {v['main_scale_m']:.2f} m, axis {v['axis_error_deg']:.1f}°, {v['kind']}"
                if "kind" in v else "") for n, v in f.items()))
    print(f"wrote {os.path.join(a.out, 'summary.json')}")
    return s

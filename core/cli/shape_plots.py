"""The figures of ``python -m core.shape`` (:mod:`core.cli.shape`), drawn with matplotlib's Agg
backend (imported only when a figure is drawn)."""

from __future__ import annotations

import math

import numpy as np

from . import figure, save

__all__ = ["plot_errors", "plot_shape", "plot_sweep"]


def plot_errors(res, path):
    """errors_rowI.png: position error along the pass for each filter (run 0), outliers marked."""
    fig, ax = figure(figsize=(7, 4))
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
    save(fig, path, dpi=90)


def plot_shape(res, path):
    """shape_rowI.png: run 0's final dipoles and PCA axes over the target's outline, plan and side."""
    fig, axes = figure(1, 2, figsize=(9, 4.2))
    t = res.case.target
    for ax, (i, j, lab) in zip(axes, ((0, 1, "plan: x–y"), (0, 2, "side: x–z"))):
        for ln in t.outline():
            ax.plot(ln[:, i], ln[:, j], color="0.6", lw=1)
        for name, mk in (("ukf", "o"), ("nhukf", "^"), ("fit", "s")):
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
    save(fig, path, dpi=90)


def plot_sweep(sw, row, path):
    """cpa_sweep.png: the bounds and the Monte-Carlo errors against the closest approach."""
    rec = sw["records"]
    c = [r["closest_approach_m"] for r in rec]
    fig, ax = figure(figsize=(7.5, 4.8))
    ax.loglog(c, [r["bound_span_m"] for r in rec], "-", color="#9467bd", label="bound: span read")
    ax.loglog(c, [r["bound_second_moment_m"] for r in rec], "-", lw=2.5, color="#17becf",
              label="bound: second-moment read")
    ax.loglog(c, [r["bound_rigid_line_m"] for r in rec], "--", color="#9467bd", label="bound: rigid line")
    for e, mk, col in (("ukf", "o", "#1f77b4"), ("nhukf", "^", "#d62728"), ("fit", "s", "#2ca02c")):
        ax.loglog(c, [max(r[f"{e}_second_moment_error_m"], 1e-6) for r in rec], mk, color=col,
                  label=f"{e.upper()}: Monte-Carlo error, second-moment read")
    ax.axhline(sw["size_to_m"], color="k", ls=":", lw=1, label=f"size to {sw['size_to_m']:.3g} m")
    ax.axhline(sw["main_scale_m"], color="0.5", ls="-.", lw=1, label=f"main scale {sw['main_scale_m']:g} m")
    if sw["bound_cpa_m"] is not None and math.isfinite(sw["bound_cpa_m"]):
        ax.axvline(sw["bound_cpa_m"], color="k", lw=1, alpha=0.5)
    from matplotlib.ticker import FormatStrFormatter
    ax.xaxis.set_major_formatter(FormatStrFormatter("%g"))
    ax.xaxis.set_minor_formatter(FormatStrFormatter("%g"))
    ax.set_xlabel("closest approach (m)")
    ax.set_ylabel("main scale: 1σ bound or median |error| (m)")
    ax.set_title(f"{row.name}: how close must the pass be? ({sw['runs']} passes per point)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="upper left")
    save(fig, path, dpi=90)

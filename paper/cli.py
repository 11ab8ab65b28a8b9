"""Command line: ``python -m paper --out DIR [--n 121] [--doc PATH] [--dpi 100] [--no-html]``.

Writes into DIR: ``html/<model>/<figure>.html`` (one interactive page per figure),
``png/<model>/<panel>.png`` (one image per panel), ``claims.json`` (the numbers behind every
verdict) and the report (``DIR/paper-reproduction.md`` unless ``--doc`` puts it elsewhere; image
links are relative to the report). The committed docs are made with

    python -m paper --out docs/paper --doc docs/paper-reproduction.md --no-html --dpi 64
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import sys

from tqdm import tqdm

from . import beyond, claims, figures, precision, report
from . import scenarios as sc


def _parser():
    p = argparse.ArgumentParser(prog="python -m paper", description=__doc__.split("\n")[0])
    p.add_argument("--out", required=True, help="output folder (created if missing)")
    p.add_argument("--n", type=int, default=121, help="grid points per axis (default 121)")
    p.add_argument("--doc", default=None, help="report path (default OUT/paper-reproduction.md)")
    p.add_argument("--dpi", type=int, default=100, help="PNG resolution; size is 5.6 × 4.4 in (default 100)")
    p.add_argument("--no-html", action="store_true", help="skip the Bokeh HTML pages")
    p.add_argument("--inline", action="store_true", help="embed BokehJS in the HTML (works offline, ~1 MB each)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    return p


def run(out, n=121, doc=None, dpi=100, html=True, inline=False, quiet=False, command=None):
    """Do everything; returns {"doc": path, "claims": path, "pngs": {...}, "htmls": {...}}."""
    if not 3 <= n <= 1000:
        raise ValueError(f"--n must be in [3, 1000]; got {n}")
    os.makedirs(out, exist_ok=True)
    doc = doc or os.path.join(out, "paper-reproduction.md")
    os.makedirs(os.path.dirname(os.path.abspath(doc)), exist_ok=True)
    # per model: the d scan, the high-precision check, 26 PNG panels, 9 HTML figures
    steps = len(sc.MODELS) * (len(beyond.SCAN_D) + 1 + 26 + (9 if html else 0))
    bar = tqdm(total=steps, desc="paper", unit="step", disable=quiet, file=sys.stderr)
    tick = lambda: bar.update(1)
    scan = {"d_m": list(beyond.SCAN_D)}
    claims_by_model, evidence, known, pngs, htmls = {}, {}, {}, {}, {}
    for model in sc.MODELS:
        bar.set_postfix_str(f"{model}: d scan")
        scan[model] = beyond.d_scan(model, n, progress=tick)
        bar.set_postfix_str(f"{model}: claims")
        claims_by_model[model] = claims.evaluate_claims(model, n, scan)
        known[model] = beyond.known_moments_summary(model, n)
        bar.set_postfix_str(f"{model}: 60-digit round-off check")
        evidence[model] = precision.evidence(model)
        tick()
        png_dir = os.path.join(out, "png", model)
        os.makedirs(png_dir, exist_ok=True)
        figs = figures.paper_figures(model, n) + figures.extra_figures(model, n, scan)
        bar.set_postfix_str(f"{model}: rendering")
        for f in figs:
            if f.line:
                pngs[(model, f.key)] = path = os.path.join(png_dir, f"{f.key}.png")
                figures.render_line_png(f, path, dpi)
                tick()
            for p in f.panels:
                pngs[(model, p.key)] = path = os.path.join(png_dir, f"{p.key}.png")
                figures.render_png(p, path, dpi)
                tick()
            if html:
                hdir = os.path.join(out, "html", model)
                os.makedirs(hdir, exist_ok=True)
                htmls[(model, f.key)] = path = os.path.join(hdir, f"{f.key}.html")
                figures.render_html(f, path, inline=inline)
                tick()
    cpath = os.path.join(out, "claims.json")
    with open(cpath, "w", encoding="utf-8") as fh:
        json.dump({"n": n, "claims": {m: [c.to_dict() for c in cs] for m, cs in claims_by_model.items()},
                   "roundoff": evidence, "d_scan": scan, "known_moments": known}, fh, indent=1)
    report.write(doc, n=n, command=command or f"python -m paper --out {out} --n {n}",
                 claims_by_model=claims_by_model, evidence_by_model=evidence, scan=scan,
                 known_summary=known, pngs=pngs, htmls=htmls)
    bar.update(bar.total - bar.n)
    bar.close()
    return {"doc": doc, "claims": cpath, "pngs": pngs, "htmls": htmls}


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    a = _parser().parse_args(argv)
    return run(a.out, n=a.n, doc=a.doc, dpi=a.dpi, html=not a.no_html, inline=a.inline, quiet=a.quiet,
               command="python -m paper " + shlex.join(argv))


if __name__ == "__main__":
    main()

"""Command line: ``python -m paper --out DIR [--n 121] [--doc PATH] [--dpi 100] [--no-html]``.

Writes into DIR: ``html/<model>/<figure>.html`` (one interactive page per figure),
``png/<model>/<panel>.png`` (one image per panel), ``claims.json`` (the numbers behind every
verdict) and the report (``DIR/paper-reproduction.md`` unless ``--doc`` puts it elsewhere; image
links are relative to the report). The committed docs are made with

    python -m paper --out docs/paper --doc docs/paper-reproduction.md --no-html --dpi 64

``--check`` recomputes every number and the report's text without rendering an image or writing
a file, and exits with status 1 (saying which section differs) unless the existing report and
``claims.json`` are exactly what the command would write. Rerun with ``--check`` appended to
the command above: it is the test that the committed document is current.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shlex
import sys

from tqdm import tqdm

from core.cli import ArgumentParser

from . import beyond, claims, figures, precision, report
from . import scenarios as sc


#: What ``--help`` says under its usage line: plain text (the module's notes are reStructuredText,
#: and their first line was a second, shorter usage line of their own).
DESCRIPTION = "Reproduce the paper's Figs. 1-6, check its claims and write the reproduction report."
EPILOG = """\
writes into OUT:
  html/<model>/<figure>.html  one interactive page per figure (not with --no-html)
  png/<model>/<panel>.png     one image per panel
  claims.json                 the numbers behind every verdict
  paper-reproduction.md       the report (or --doc PATH; its image links are relative to it)

the committed docs are made with:
  python -m paper --out docs/paper --doc docs/paper-reproduction.md --no-html --dpi 64
and the same command with --check appended tests that they are current."""


def _parser():
    p = ArgumentParser(prog="python -m paper", description=DESCRIPTION, epilog=EPILOG,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", required=True, help="output folder (created if missing)")
    p.add_argument("--n", type=int, default=121, help="grid points per axis (default 121)")
    p.add_argument("--doc", default=None, help="report path (default OUT/paper-reproduction.md)")
    p.add_argument("--dpi", type=int, default=100, help="PNG resolution; size is 5.6 × 4.4 in (default 100)")
    p.add_argument("--no-html", action="store_true", help="skip the Bokeh HTML pages")
    p.add_argument("--inline", action="store_true", help="embed BokehJS in the HTML (works offline, ~1 MB each)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--check", action="store_true",
                   help="write nothing; exit 1 unless the report and claims.json are current")
    return p


#: Relative tolerance of claims.json's numbers in ``--check``: a rerun's sums in another order
#: (BLAS threads, compiled or cached kernels) move the last bits (1e-16 relative, 1e-12 seen on a
#: rank-deficient Γ's direction cosine); a change of the model moves them by far more.
CLAIMS_RTOL = 1e-9


def same_numbers(a, b, rtol=CLAIMS_RTOL):
    """Whether two JSON values are equal, floats to ``rtol`` (relative) or 1e-300 absolute."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(same_numbers(a[k], b[k], rtol) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(same_numbers(x, y, rtol) for x, y in zip(a, b))
    if isinstance(a, float) or isinstance(b, float):
        if not isinstance(a, (int, float)) or not isinstance(b, (int, float)):
            return False
        if a != a or b != b:  # NaN (json writes it): equal only to NaN
            return a != a and b != b
        return a == b or abs(a - b) <= rtol * max(abs(a), abs(b)) + 1e-300
    return a == b


def stale_sections(text, committed, sections):
    """Headings (or indices) of the rendered ``sections`` texts not found verbatim in the
    committed report, in order: the check of :func:`run` with ``check=True``."""
    stale, pos = [], 0
    for i, part in enumerate(sections):
        at = committed.find(part, pos)
        if at < 0:
            head = next((line for line in part.splitlines() if line.startswith("#")), f"section {i}")
            stale.append(head)
        else:
            pos = at + len(part)
    if not stale and text != committed:
        stale.append("(the report as a whole: a section is missing, extra or out of order)")
    return stale


def run(out, n=121, doc=None, dpi=100, html=True, inline=False, quiet=False, command=None,
        check=False, sections=None):
    """Do everything; returns {"doc": path, "claims": path, "pngs": {...}, "htmls": {...}}.

    ``check=True`` computes all numbers and the text but renders and writes nothing; it returns
    {"doc", "claims", "stale": [what differs from the files on disk: section headings, or
    claims.json]}. ``sections``: check only these of :data:`paper.report.SECTIONS`, each of
    which must appear verbatim and in order (default: all, and the report must match exactly)."""
    if not 3 <= n <= 1000:
        raise ValueError(f"--n must be in [3, 1000]; got {n}")
    doc = doc or os.path.join(out, "paper-reproduction.md")
    if not check:
        os.makedirs(out, exist_ok=True)
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
        if not check:
            os.makedirs(png_dir, exist_ok=True)
        figs = figures.paper_figures(model, n) + figures.extra_figures(model, n, scan)
        bar.set_postfix_str(f"{model}: rendering")
        for f in figs:
            if f.line:
                pngs[(model, f.key)] = path = os.path.join(png_dir, f"{f.key}.png")
                if not check:
                    figures.render_line_png(f, path, dpi)
                tick()
            for p in f.panels:
                pngs[(model, p.key)] = path = os.path.join(png_dir, f"{p.key}.png")
                if not check:
                    figures.render_png(p, path, dpi)
                tick()
            if html:
                hdir = os.path.join(out, "html", model)
                htmls[(model, f.key)] = path = os.path.join(hdir, f"{f.key}.html")
                if not check:
                    os.makedirs(hdir, exist_ok=True)
                    figures.render_html(f, path, inline=inline)
                tick()
    cpath = os.path.join(out, "claims.json")
    numbers = json.dumps({"n": n, "claims": {m: [c.to_dict() for c in cs] for m, cs in claims_by_model.items()},
                          "roundoff": evidence, "d_scan": scan, "known_moments": known}, indent=1)
    ctx = report.Context(n=n, command=command or f"python -m paper --out {out} --n {n}",
                         claims_by_model=claims_by_model, evidence_by_model=evidence, scan=scan,
                         known_summary=known, pngs=pngs, htmls=htmls,
                         doc_dir=os.path.dirname(os.path.abspath(doc)))
    bar.update(bar.total - bar.n)
    bar.close()
    if check:
        chosen = report.SECTIONS if sections is None else sections
        parts = [report.render(ctx, [s]) for s in chosen]
        text = report.render(ctx, chosen)
        committed = _read(doc)
        stale = stale_sections(text if sections is None else committed, committed, parts)
        if not same_numbers(json.loads(_read(cpath) or "null"), json.loads(numbers)):
            stale.append(f"{cpath} (the numbers behind the verdicts)")
        return {"doc": doc, "claims": cpath, "stale": stale}
    with open(cpath, "w", encoding="utf-8") as fh:
        fh.write(numbers)
    with open(doc, "w", encoding="utf-8") as fh:
        fh.write(report.render(ctx))
    return {"doc": doc, "claims": cpath, "pngs": pngs, "htmls": htmls}


def _read(path):
    """A text file's contents, '' if it does not exist."""
    if not os.path.exists(path):
        return ""
    with open(path, encoding="utf-8") as fh:
        return fh.read()


def committed_command(doc):
    """The arguments of the ``python -m paper`` command named in a report's first lines."""
    with open(doc, encoding="utf-8") as fh:
        head = fh.read(2000)
    found = re.search(r"Generated by `python -m paper ([^`]*)`", head)
    if not found:
        raise ValueError(f"{doc} does not say which `python -m paper` command generated it")
    return shlex.split(found.group(1))


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    a = _parser().parse_args(argv)
    made = "python -m paper " + shlex.join([v for v in argv if v not in ("--check", "--quiet")])
    res = run(a.out, n=a.n, doc=a.doc, dpi=a.dpi, html=not a.no_html, inline=a.inline, quiet=a.quiet,
              command=made, check=a.check)
    if a.check:
        if res["stale"]:
            print(f"{res['doc']} is not current; differing: " + "; ".join(res["stale"])
                  + f". Regenerate with: {made}", file=sys.stderr)
            sys.exit(1)
        print(f"{res['doc']} and {res['claims']} are current.")
    else:
        print(f"wrote the report {res['doc']} (numbers in {res['claims']}; {len(res['pngs'])} PNG "
              f"panels, {len(res['htmls'])} HTML pages under {a.out})")
    return res


if __name__ == "__main__":
    main()

"""A study an analyst can keep (spec §12): scenario files, a self-contained report, a script that
reproduces its numbers through core, and batches of variants (``python -m study``, docs/study.md).

Built on the dashboard's own state and computations (``app``), so that a file is checked as a
link is and the report's numbers are the page's.
"""

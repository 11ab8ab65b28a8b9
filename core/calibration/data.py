"""Seed 004's cases, and readings with attitudes from CSV text or files (with upload limits).

A calibration CSV has a header row naming at least the columns :data:`CSV_COLUMNS` (extra columns
are ignored), then one row per attitude: B1, B2, B3 in nT, psi, theta, phi in rad. UTF-8 with or
without a BOM, with Unix or Windows line ends. Whatever else arrives (a binary file, a line of
megabytes, a cell of 1e308 or NaN, a column named twice, more than :data:`MAX_CSV_ROWS` rows or
:data:`MAX_CSV_BYTES` bytes) is refused with one ValueError that says what was wrong and what is
accepted, before any computation starts.
"""

from __future__ import annotations

import csv
import os
from pathlib import Path

import numpy as np

from .validation import ANGLE_LIMIT

#: Columns a calibration CSV must have (extra columns are ignored): B in nT, angles in rad.
CSV_COLUMNS = ("B1", "B2", "B3", "psi", "theta", "phi")
#: Largest calibration log accepted, in readings (data rows): 1 000 000 readings, a 28-hour log
#: at 10 Hz, solve in under a minute on the CLI (docs/calibration.md); memory grows linearly.
MAX_CSV_ROWS = 1_000_000
#: Largest calibration CSV accepted, in bytes (128 MiB): 1 000 000 rows of up to ~130 bytes,
#: room for a timestamp and a few extra columns beside the six that are read.
MAX_CSV_BYTES = 128 * 2 ** 20
#: Longest line accepted (characters): a row of readings is ~60; a longer line is not one.
MAX_LINE_CHARS = 4096
#: Largest |reading| accepted (nT): the geomagnetic field is ≤ 70 000 nT and a ship's
#: interference a few times that; 1e7 nT (10 mT) or more means another unit (pT?) or a wrong file.
MAX_READING_NT = 1e7

#: Seed 004's simulation (§2.2): Be (nT), K, Bp (nT), attitude ranges (deg), 12 attitudes, and
#: its errors "of at most" 100 nT on B and 0.05° on each angle (modelled as uniform, see
#: :func:`simulate_ship_data`), and the estimate it reports.
SEED004_SIMULATION = {
    "be": (34000.0, 2000.0, 35000.0),
    "K": ((0.95, -0.003, 0.003), (0.003, 0.95, -0.03), (0.03, -0.03, 1.05)),
    "Bp": (1500.0, -800.0, 1800.0),
    "heading_deg": (0.0, 360.0), "roll_deg": (-20.0, 20.0), "pitch_deg": (-15.0, 15.0),
    "n_attitudes": 12, "noise_nt": 100.0, "angle_noise_deg": 0.05,
    "paper_K": ((0.9499, -0.0036, 0.0030), (0.0027, 0.9502, -0.0303), (0.0295, -0.0296, 1.0499)),
    "paper_Bp": (1497.0, -809.0, 1806.0),
    "paper_iterations": 300,
}
#: Seed 004's ship-model experiment (§3, Table 1): Be (nT) and the K, Bp (nT) it reports, and
#: the RMS error (nT) and largest relative error of its geomagnetic solution.
SEED004_TABLE1 = {
    "be": (34425.0, 1961.0, 35898.0),
    "paper_K": ((0.98575, 0.08153, 0.06221), (-0.06233, 0.83517, -0.02987),
                (-0.02999, -0.07748, 1.06615)),
    "paper_Bp": (2011.1, -2886.8, 2054.6),
    "paper_be_rms_nt": 266.0, "paper_be_max_rel": 0.019,
}

_ACCEPTED = (f"a UTF-8 CSV with a header row naming {', '.join(CSV_COLUMNS)} (B in nT, angles in "
             "rad)")


def _text(text):
    """The CSV as str, after the checks that need no parsing (size, NUL bytes, encoding)."""
    if isinstance(text, (bytes, bytearray, memoryview)):
        raw = bytes(text)
        if len(raw) > MAX_CSV_BYTES:
            raise ValueError(f"the CSV has {len(raw):,} bytes; the largest accepted is "
                             f"{MAX_CSV_BYTES:,} bytes ({MAX_CSV_BYTES // 2 ** 20} MiB)")
        if b"\x00" in raw:
            raise ValueError(f"the file contains NUL bytes: it is binary, not CSV text; expected "
                             f"{_ACCEPTED}")
        try:
            text = raw.decode("utf-8-sig")
        except UnicodeDecodeError as exc:
            raise ValueError(f"the file is not UTF-8 text (byte {exc.start:,} is not valid UTF-8); "
                             f"expected {_ACCEPTED}") from None
    elif isinstance(text, str):
        if len(text) > MAX_CSV_BYTES:
            raise ValueError(f"the CSV has {len(text):,} characters; the largest accepted is "
                             f"{MAX_CSV_BYTES:,} bytes ({MAX_CSV_BYTES // 2 ** 20} MiB)")
        if "\x00" in text:
            raise ValueError(f"the text contains NUL characters: it is binary, not CSV text; "
                             f"expected {_ACCEPTED}")
    else:
        raise ValueError(f"the CSV must be given as str or bytes; got {type(text).__name__}")
    return text.lstrip("\ufeff").replace("−", "-")


def _cells(line):
    try:
        return next(csv.reader([line]))
    except csv.Error as exc:
        raise ValueError(f"a line cannot be read as CSV ({exc}); expected {_ACCEPTED}") from None


def _locate(lines, numbers, idx):
    """The first cell of the data lines that is not a number (a clear message); None if all are."""
    for n, line in zip(numbers, lines):
        row = _cells(line)
        for c, col in zip(idx, CSV_COLUMNS):
            cell = row[c].strip() if c < len(row) else ""
            try:
                float(cell)
            except ValueError:
                shown = repr(cell) if len(cell) <= 40 else repr(cell[:40]) + "…"
                return f"line {n}, column {col}: {shown} is not a number"
    return None


def parse_attitude_csv(text):
    """Readings and attitudes from CSV text with columns B1, B2, B3 (nT), psi, theta, phi (rad).

    Parameters
    ----------
    text : str or bytes
        The CSV: a header row first, then one row per attitude; extra columns are ignored, blank
        lines skipped; UTF-8, a BOM and Windows line ends accepted; at most
        :data:`MAX_CSV_BYTES` bytes, :data:`MAX_CSV_ROWS` rows and :data:`MAX_LINE_CHARS`
        characters per line.

    Returns
    -------
    B : ndarray, shape (N, 3)
        Readings (nT).
    attitudes : ndarray, shape (N, 3)
        ψ, θ, φ (rad).

    Raises
    ------
    ValueError
        One message: too large, binary (NUL bytes) or not UTF-8, a line too long, missing or
        duplicated columns, a non-numeric or non-finite cell, |B| ≥ :data:`MAX_READING_NT`, an
        |angle| > 2π (degrees given by mistake), or fewer than 4 attitudes (the 12 coefficients
        need at least 4 × 3 readings).

    Notes
    -----
    Time and memory are linear in the size of the text (numpy's C reader; the cell-by-cell scan
    that names a bad cell runs only when there is one).
    """
    text = _text(text)
    lines = text.splitlines()
    if max(map(len, lines), default=0) > MAX_LINE_CHARS:
        longest = next(k for k, line in enumerate(lines) if len(line) > MAX_LINE_CHARS)
        raise ValueError(f"line {longest + 1} has {len(lines[longest]):,} characters; a row of "
                         f"readings has a few dozen and at most {MAX_LINE_CHARS:,} are accepted "
                         f"(expected {_ACCEPTED})")
    numbers = [n for n, line in enumerate(lines, start=1) if line.strip(' \t,"')]
    if not numbers:
        raise ValueError(f"the CSV is empty; expected a header row with columns {', '.join(CSV_COLUMNS)}")
    header = [c.strip() for c in _cells(lines[numbers[0] - 1])]
    missing = [c for c in CSV_COLUMNS if c not in header]
    if missing:
        found = ", ".join(h[:20] for h in header[:12]) + (", …" if len(header) > 12 else "")
        raise ValueError(f"the CSV lacks column(s) {', '.join(missing)}; it needs {', '.join(CSV_COLUMNS)} "
                         f"(B in nT, angles in rad); found {found or 'none'}")
    twice = [c for c in CSV_COLUMNS if header.count(c) > 1]
    if twice:
        raise ValueError(f"the header names column(s) {', '.join(twice)} more than once; each of "
                         f"{', '.join(CSV_COLUMNS)} must appear exactly once")
    numbers = numbers[1:]
    if len(numbers) > MAX_CSV_ROWS:
        raise ValueError(f"the CSV has {len(numbers):,} rows of readings; the largest accepted is "
                         f"{MAX_CSV_ROWS:,}")
    if len(numbers) < 4:
        raise ValueError(f"the CSV has {len(numbers)} attitude(s); the 12 coefficients need at "
                         "least 4 (3 readings each)")
    body = [lines[n - 1] for n in numbers]
    idx = [header.index(c) for c in CSV_COLUMNS]
    try:
        data = np.loadtxt(body, delimiter=",", quotechar='"', usecols=idx, dtype=float, ndmin=2,
                          comments=None)
    except ValueError:
        raise ValueError(_locate(body, numbers, idx)
                         or f"the rows cannot be read as numbers; expected {_ACCEPTED}") from None
    bad = ~np.isfinite(data)
    if bad.any():
        r, j = map(int, np.argwhere(bad)[0])
        raise ValueError(f"line {numbers[r]}, column {CSV_COLUMNS[j]}: {data[r, j]:g} is not a "
                         "finite number")
    big = np.abs(data[:, :3]) >= MAX_READING_NT
    if big.any():
        r, j = map(int, np.argwhere(big)[0])
        raise ValueError(f"line {numbers[r]}, column {CSV_COLUMNS[j]}: {data[r, j]:g} nT is not a "
                         f"magnetometer reading (|B| < {MAX_READING_NT:g} nT accepted; B must be in "
                         "nT)")
    big = np.abs(data[:, 3:]) > ANGLE_LIMIT
    if big.any():
        r, j = map(int, np.argwhere(big)[0])
        raise ValueError(f"line {numbers[r]}, column {CSV_COLUMNS[3 + j]}: {data[r, 3 + j]:g} exceeds 2π; "
                         "angles must be in radians (degrees given by mistake? multiply by π/180)")
    return data[:, :3], data[:, 3:]


def read_attitude_csv(path):
    """:func:`parse_attitude_csv` of a file (path); ValueError if it is not a readable regular
    file or is larger than :data:`MAX_CSV_BYTES` (checked before reading it)."""
    p = Path(path)
    too_big = (f"{path} has more than {MAX_CSV_BYTES:,} bytes; the largest CSV accepted is "
               f"{MAX_CSV_BYTES:,} bytes ({MAX_CSV_BYTES // 2 ** 20} MiB)")
    try:
        if not p.is_file():
            raise ValueError(f"cannot read {path}: " + ("it is not a regular file" if p.exists()
                                                       else "no such file"))
        with p.open("rb") as f:
            if os.fstat(f.fileno()).st_size > MAX_CSV_BYTES:
                raise ValueError(too_big)
            raw = f.read()
    except OSError as exc:
        raise ValueError(f"cannot read {path}: {exc.strerror or exc}") from None
    if len(raw) > MAX_CSV_BYTES:  # grew since fstat
        raise ValueError(too_big)
    return parse_attitude_csv(raw)


def seed004_table1_path():
    """Path of ``data/seed004_table1.csv`` (seed 004's Table 1).

    Looked up next to the package (a clone or an editable install: ``<repo>/data``), then in
    ``./data`` (the Docker image's working directory holds the repository).
    """
    for base in (Path(__file__).resolve().parents[2], Path.cwd()):
        p = base / "data" / "seed004_table1.csv"
        if p.is_file():
            return p
    raise ValueError("data/seed004_table1.csv not found next to the package or in ./data")


def seed004_table1():
    """Seed 004's Table 1: readings (12, 3) in nT and attitudes (12, 3) in rad."""
    return read_attitude_csv(seed004_table1_path())

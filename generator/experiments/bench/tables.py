"""The CSV files of `s2gen bench`.

Input: a `BenchReport`. Output: ``bench.csv`` (one row per work-precision run, columns
`WP_COLUMNS`), ``per_step.csv`` and, for the sections that ran, ``long.csv`` (one row per
window of each long run), ``stability.csv`` and ``scaling.csv`` (one row per record, the
dataclass fields as columns). Non-finite numbers are written as empty cells.

Example:
    >>> _cell(float("nan")), _cell(1 / 3), _cell("ok")
    ('', '0.333333', 'ok')
"""

from __future__ import annotations

import csv
import dataclasses
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .model import BenchReport, ScaleRow, StabRow, WPRow

#: Columns of bench.csv: the fields of `WPRow`, the wall time named with its unit.
WP_COLUMNS = tuple("wall_s" if f.name == "wall" else f.name for f in dataclasses.fields(WPRow))


def _cell(x: Any) -> str:
    if isinstance(x, float):
        return "" if not np.isfinite(x) else f"{x:.6g}"
    return str(x)


def _write_csv(path: Path, header: Sequence[str], rows: Sequence[Sequence[Any]]) -> Path:
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        for r in rows:
            w.writerow([_cell(x) for x in r])
    return path


def write_tables(report: BenchReport) -> list[Path]:
    """bench.csv, per_step.csv and, when run, long.csv, stability.csv, scaling.csv."""
    out = report.out
    files = []
    if any(ex.rows for ex in report.examples):
        rows = [dataclasses.astuple(r) for ex in report.examples for r in ex.rows]
        files.append(_write_csv(out / "bench.csv", WP_COLUMNS, rows))
        keys = (
            "system",
            "method",
            "h",
            "steps",
            "c_us",
            "numpy_us",
            "reference_us",
            "numpy_over_c",
            "reference_over_c",
        )
        per = [
            [row.get(k, math.nan) for k in keys] for ex in report.examples for row in ex.per_step
        ]
        files.append(_write_csv(out / "per_step.csv", keys, per))
    long_rows = [
        [s.example, s.label, s.method, s.h, s.rtol, t, e, u, qw, dl, s.status]
        for ex in report.examples
        for s in (*ex.long, *ex.encounters)
        for t, e, u, qw, dl in zip(s.t, s.dE, s.unit, s.qw, s.dL)
    ]
    if long_rows:
        head = (
            "example",
            "label",
            "method",
            "h",
            "rtol",
            "t_end",
            "window_max_dE",
            "window_max_unit",
            "window_max_q_dot_w",
            "window_max_dL",
            "status",
        )
        files.append(_write_csv(out / "long.csv", head, long_rows))
    for name, records, kind in (
        ("stability.csv", report.stability, StabRow),
        ("scaling.csv", report.scaling, ScaleRow),
    ):
        if records:
            names = [f.name for f in dataclasses.fields(kind)]
            values = [dataclasses.astuple(r) for r in records]
            files.append(_write_csv(out / name, names, values))
    return files

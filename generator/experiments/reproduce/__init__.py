"""`s2gen reproduce`: the paper's examples rerun on the emitted code, tables and figures.

The package, one responsibility per module: `paper` (the examples, their runs and the printed
values), `records` (results), `runner` (running and the tables), `figures` (paper-style PNGs),
`band` (the chaos bands: the examples' runs as ensembles of perturbed members, on `s2gen.ensemble`),
`command` (the command-line parser). Public names are re-exported here and imported on first
use, so the command-line parser does not import the rest.

Example:
    >>> from s2gen.experiments.reproduce import EXAMPLES
    >>> "double_pendulum" in EXAMPLES
    True
"""

from __future__ import annotations

import importlib
from typing import Any

_WHERE = {
    "ADAPTIVE": "runner",
    "Band": "band",
    "COLUMN_DEFINITIONS": "runner",
    "CSV_COLUMNS": "runner",
    "EXAMPLES": "paper",
    "METRICS": "runner",
    "PAPER_METRICS": "runner",
    "Example": "paper",
    "ExampleResult": "records",
    "PaperRun": "paper",
    "Report": "records",
    "RunResult": "records",
    "add_parser": "command",
    "chaos_band": "band",
    "example_figures": "figures",
    "face_kinetic_energy": "figures",
    "integrate": "runner",
    "reproduce": "runner",
    "run_example": "runner",
    "run_one": "runner",
    "select_examples": "runner",
    "write_csv": "runner",
    "write_markdown": "runner",
}

__all__ = [
    "ADAPTIVE",
    "COLUMN_DEFINITIONS",
    "CSV_COLUMNS",
    "EXAMPLES",
    "METRICS",
    "PAPER_METRICS",
    "Band",
    "Example",
    "ExampleResult",
    "PaperRun",
    "Report",
    "RunResult",
    "add_parser",
    "chaos_band",
    "example_figures",
    "face_kinetic_energy",
    "integrate",
    "reproduce",
    "run_example",
    "run_one",
    "select_examples",
    "write_csv",
    "write_markdown",
]


def __getattr__(name: str) -> Any:
    module = _WHERE.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{module}"), name)

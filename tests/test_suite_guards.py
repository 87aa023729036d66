"""The test suite's own guards: a hanging test fails by itself instead of stalling the run."""

from __future__ import annotations

import subprocess
import sys
import time
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_a_hanging_test_fails_alone_within_its_timeout(tmp_path: Path) -> None:
    """pytest-timeout is installed and active: a test sleeping past a 1 s limit fails, the one
    beside it passes, and the run ends long before the sleep would."""
    (tmp_path / "test_hang.py").write_text(
        "import time\n\ndef test_hangs():\n    time.sleep(60)\n\ndef test_fine():\n    pass\n"
    )
    start = time.monotonic()
    run = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-o", "timeout=1"],
        check=False,
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert time.monotonic() - start < 50
    assert run.returncode == 1, run.stdout
    assert "1 failed, 1 passed" in run.stdout and "Timeout" in run.stdout


def test_the_default_run_has_a_per_test_timeout() -> None:
    """The project's pytest settings set a finite per-test limit."""
    options = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["pytest"]
    assert 0 < float(options["ini_options"]["timeout"]) <= 1800

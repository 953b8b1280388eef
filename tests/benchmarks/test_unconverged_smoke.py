"""Smoke test of ``scripts/bench_unconverged.py`` (the emulator stopped by a small cap)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_capped_run_is_flagged_and_scored(tmp_path: Path) -> None:
    """The initial design alone (5 runs on a 2-parameter case): unconverged, flagged, scored."""
    out = tmp_path / "rows.json"
    proc = subprocess.run(
        [sys.executable, str(ROOT / "scripts" / "bench_unconverged.py"), "--cases", "holdout3_p2",
         "--beyond", "0", "--out", str(out)],
        cwd=ROOT, capture_output=True, text=True, timeout=900)  # a hang guard only: CPU ~5 s
    assert proc.returncode == 0, proc.stderr[-2000:]
    (row,) = json.loads(out.read_text())
    assert row["cap"] == row["runs"] == 5 and row["converged"] is False
    assert row["err_own_sd"] >= 0 and 0 < row["sd_ratio_min"] <= row["sd_ratio_max"]
    assert "| holdout3_p2 | 2 | 5 | 5 | no |" in proc.stdout

"""``scripts/fault_injection.py`` at CI size: kills, no repeated run, a sound store, same result."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "fault_injection.py"


@pytest.mark.slow
def test_fault_injection_small(tmp_path: Path) -> None:
    report_path = tmp_path / "report.json"
    done = subprocess.run(
        [sys.executable, str(SCRIPT), "--kills", "2", "--jobs", "emcee,fit", "--small",
         "--folder", str(tmp_path / "run"), "--json", str(report_path), "--timeout", "900"],
        capture_output=True, text=True, env=dict(os.environ, OMP_NUM_THREADS="1"), timeout=1200,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    report = json.loads(report_path.read_text())
    assert report["kills"] >= 1 and report["processes_killed"] >= report["kills"]
    assert report["repeated_beyond_in_flight"] == 0
    assert report["integrity_failures"] == 0 and report["integrity_checks"] == report["kills"] + 1
    assert report["extra_calls"] <= report["in_flight_at_kills"]
    emcee = report["posterior"]["emcee"]
    assert emcee["max_sample_diff"] == 0.0  # the resumed chain is the uninterrupted chain
    assert report["posterior"]["fit"]["max_prediction_diff"] <= 1e-9

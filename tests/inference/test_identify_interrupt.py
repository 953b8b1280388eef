"""SIGTERM stops ``torchshm.identify`` at once with one line; the store keeps every finished run."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from torchshm import EvaluationStore

HERE = Path(__file__).resolve().parent

SCRIPT = """
import sys
sys.path.insert(0, {here!r})
from inference_models import SlowCountingModel, linear_gaussian_problem
from torchshm import identify
problem = linear_gaussian_problem(model=SlowCountingModel({counter!r}, delay=0.05), store={store!r})
identify(problem, "vbmc", seed=0, display="off")
print("finished")
"""


@pytest.mark.slow
def test_sigterm_stops_identify_and_keeps_its_runs(tmp_path: Path) -> None:
    counter, store = tmp_path / "calls.txt", tmp_path / "store.sqlite"
    script = tmp_path / "run.py"
    script.write_text(SCRIPT.format(here=str(HERE), counter=str(counter), store=str(store)))
    process = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True,
                               env={**os.environ, "OMP_NUM_THREADS": "1"})
    deadline = time.monotonic() + 300
    while process.poll() is None and time.monotonic() < deadline and (
            not counter.exists() or len(counter.read_text().splitlines()) < 15):
        time.sleep(0.05)
    process.send_signal(signal.SIGTERM)
    out, err = process.communicate(timeout=300)
    assert process.returncode == 128 + signal.SIGTERM and "finished" not in out
    lines = [line for line in err.splitlines() if "stopped by" in line]
    assert lines == [f"identify (vbmc) stopped by SIGTERM; every finished model run is kept in "
                     f"{store}; to resume, call it again with the same store"], err
    assert "Traceback" not in err
    calls = len(counter.read_text().splitlines())
    kept = EvaluationStore(store).count(status="ok")
    assert calls - 1 <= kept <= calls and EvaluationStore(store).check().ok

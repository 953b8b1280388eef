"""method="emulator" killed with SIGKILL mid-round resumes without repeating a finished run.

A subprocess identifies the linear-Gaussian data with a slow, curved model that logs every run
it makes; it is killed while a batch is running, then run again to the end on the same store. No
run that had finished (was in the store) at the kill is made again, and the result equals an
uninterrupted run's to Monte Carlo error (the uninterrupted run meets the stop rule after five
rounds of five runs). The uninterrupted run goes on beside the killed one (two processes).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from torchshm.storage import EvaluationStore

HERE = Path(__file__).resolve().parent

SCRIPT = """
import json, sys
sys.path.insert(0, {here!r})
from inference_models import SlowCountingModel, linear_gaussian_problem
import torch
import torchshm


class Curved(SlowCountingModel):  # nonlinear in θp: the emulator needs several rounds
    def __call__(self, theta_p):
        t = torch.as_tensor(theta_p, dtype=torch.float64)
        bend = torch.sin(3 * t[..., :1, None]) * self.basis[1] + t[..., 1:, None] ** 2 * self.basis[0]
        return super().__call__(t) + 0.2 * bend


model = Curved({counter!r}, delay=0.2)
model.identity = "slow-curved-model-v1"
problem = linear_gaussian_problem(model=model, store={store!r})
post = torchshm.identify(problem, "emulator", seed=0, n_walkers=16, n_steps=100,
                         final_steps=300, n_evidence=2000)
json.dump({{"mean": post.samples.mean(0).tolist(), "sd": post.samples.std(0).tolist(),
           "log_z": post.log_evidence, "runs": post.n_model_evaluations,
           "converged": post.converged}}, open({out!r}, "w"))
"""


def _start(tmp: Path, name: str) -> tuple[subprocess.Popen, Path, Path, Path]:
    counter, store, out = tmp / f"{name}.calls", tmp / f"{name}.sqlite", tmp / f"{name}.json"
    code = SCRIPT.format(here=str(HERE), counter=str(counter), store=str(store), out=str(out))
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    return subprocess.Popen([sys.executable, "-c", code], env=env), counter, store, out


def _lines(path: Path) -> list[str]:
    return path.read_text().splitlines() if path.exists() else []


def _finished(store: Path) -> set[tuple[float, ...]]:
    theta, _ = EvaluationStore(store).all("slow-curved-model-v1")
    return {tuple(np.round(row, 9)) for row in np.asarray(theta).tolist()}


@pytest.mark.slow
def test_kill_mid_round_then_resume(tmp_path: Path) -> None:
    ref_proc, _, _, ref_out = _start(tmp_path, "uninterrupted")
    proc, counter, store, out = _start(tmp_path, "killed")
    deadline = time.time() + 600
    while len(_lines(counter)) < 7 and time.time() < deadline and proc.poll() is None:
        time.sleep(0.05)  # round 0 is 5 runs: 7 lines means inside the second batch
    assert proc.poll() is None, "the run ended before it could be killed"
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    finished = _finished(store)
    n_before = len(_lines(counter))
    assert not out.exists() and len(finished) >= 5

    rerun = subprocess.run([sys.executable, "-c", SCRIPT.format(
        here=str(HERE), counter=str(counter), store=str(store), out=str(out))],
        env={**os.environ, "OMP_NUM_THREADS": "1"}, timeout=900)
    assert rerun.returncode == 0
    again = [tuple(np.round([float(v) for v in line.split()], 9))
             for line in _lines(counter)[n_before:]]
    assert again, "the rerun made no run: nothing was left to resume"
    assert not finished.intersection(again), "a finished run was repeated"

    assert ref_proc.wait(timeout=900) == 0
    resumed, reference = json.loads(out.read_text()), json.loads(ref_out.read_text())
    assert reference["converged"]  # the comparison is between accurate posteriors
    sd = np.array(reference["sd"])
    assert np.all(np.abs(np.array(resumed["mean"]) - reference["mean"]) < 0.2 * sd)
    assert np.all(np.abs(np.array(resumed["sd"]) / sd - 1) < 0.2)
    assert abs(resumed["log_z"] - reference["log_z"]) < 0.1

"""A killed run loses nothing: VBMC on a store and emcee on an HDF5 backend resume.

VBMC (acceptance): a run in a subprocess with a slow, counting user model (0.05 s per call, one
counter-file line per call) is SIGKILLed once the store holds some evaluations; the rerun on the
same store starts from them, makes fewer new model calls than it uses, and evaluates none of
the first run's finished θp again.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pytest
from inference_models import SlowCountingModel, linear_gaussian_problem

from torchshm import EvaluationStore, identify

HERE = Path(__file__).resolve().parent

SCRIPT = """
import json, sys
sys.path.insert(0, {here!r})
from inference_models import SlowCountingModel, linear_gaussian_problem
from torchshm import identify
model = SlowCountingModel({counter!r}, delay=0.05)
problem = linear_gaussian_problem(model=model, store={store!r})
post = identify(problem, "vbmc", seed=0, display="off")
json.dump({{"n_model_evaluations": post.n_model_evaluations, "converged": post.converged,
           "diagnostics": post.diagnostics}}, open({result!r}, "w"))
"""


def _lines(path: Path) -> list[str]:
    return path.read_text().splitlines() if path.exists() else []


def _keys(rows: np.ndarray) -> set[tuple[float, ...]]:
    return {tuple(float(f"{v:.11e}") for v in row) for row in np.atleast_2d(rows)}


@pytest.mark.slow
def test_killed_vbmc_run_is_resumed_from_its_store(tmp_path: Path) -> None:
    counter, store, result = tmp_path / "calls.txt", tmp_path / "store.sqlite", tmp_path / "out.json"
    script = tmp_path / "run.py"
    script.write_text(SCRIPT.format(here=str(HERE), counter=str(counter), store=str(store), result=str(result)))
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    proc = subprocess.Popen([sys.executable, str(script)], env=env)
    deadline = time.monotonic() + 300
    while len(_lines(counter)) < 45 and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert proc.returncode == -signal.SIGKILL and not result.exists(), "the first run finished before the kill"
    model = SlowCountingModel(counter)
    first, _ = EvaluationStore(store).all(model)
    first_calls = len(_lines(counter))
    assert 40 <= first.shape[0] <= first_calls

    done = subprocess.run([sys.executable, str(script)], env=env, timeout=600)
    assert done.returncode == 0
    out = json.loads(result.read_text())
    new = np.array([[float(v) for v in line.split()] for line in _lines(counter)[first_calls:]])
    assert out["n_model_evaluations"] == new.shape[0]
    assert not (_keys(first) & _keys(new)), "a finished evaluation of the first run was repeated"
    d = out["diagnostics"]
    assert d["n_reused_points"] >= first.shape[0]
    used = d["n_precomputed"] + d["vbmc_func_count"]
    assert out["n_model_evaluations"] < used
    assert out["converged"]


def test_emcee_chain_resumes_from_its_backend(tmp_path: Path) -> None:
    path = tmp_path / "chain.h5"
    problem = linear_gaussian_problem()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        short = identify(problem, "emcee", seed=1, n_walkers=8, n_steps=30, burn=10, backend_path=path)
        assert short.n_model_evaluations == 8 * 31  # the initial walkers, then 30 steps
        more = identify(linear_gaussian_problem(), "emcee", seed=1, n_walkers=8, n_steps=50, burn=10,
                        backend_path=path)
        full = identify(linear_gaussian_problem(), "emcee", seed=1, n_walkers=8, n_steps=50, burn=10)
    assert more.diagnostics["n_resumed_steps"] == 30 and more.diagnostics["n_steps"] == 50
    # only the remaining steps, nothing recomputed (plus the output check's one run on this new
    # problem: the check runs the method's first point, which a resumed chain does not revisit)
    assert more.n_model_evaluations == 8 * 20 + more.diagnostics.get("n_check_evaluations", 0)
    assert np.array_equal(more.samples[: 20 * 8], short.samples)  # the first run's chain is kept
    # continuing from the stored state and random state is the same chain as one long run
    assert np.allclose(more.samples, full.samples, rtol=0, atol=1e-12)


def test_emcee_backend_of_another_shape_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "chain.h5"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        identify(linear_gaussian_problem(), "emcee", n_walkers=8, n_steps=5, burn=0, backend_path=path)
        with pytest.raises(ValueError, match="shape of the backend"):
            identify(linear_gaussian_problem(), "emcee", n_walkers=10, n_steps=5, burn=0, backend_path=path)


def test_emcee_backend_of_another_problem_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "chain.h5"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        identify(linear_gaussian_problem(seed=3), "emcee", n_walkers=8, n_steps=5, burn=0, backend_path=path)
        with pytest.raises(ValueError, match="started for another problem"):
            identify(linear_gaussian_problem(seed=4), "emcee", n_walkers=8, n_steps=10, burn=0, backend_path=path)


def test_emcee_settings_are_checked_before_sampling() -> None:
    with pytest.raises(ValueError, match=r"thin \(method.thin\) must be an integer >= 1"):
        identify(linear_gaussian_problem(), "emcee", n_walkers=8, n_steps=5, burn=0, thin=0)
    with pytest.raises(ValueError, match=r"n_walkers \(method.n_walkers\) must be at least twice"):
        identify(linear_gaussian_problem(), "emcee", n_walkers=3, n_steps=5, burn=0)

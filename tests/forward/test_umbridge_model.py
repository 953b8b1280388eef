"""UMBridgeModel: a model served over UM-Bridge on the loopback, identified through the store."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
import requests
import torch

import torchshm
from torchshm import Measurements, Normal, Problem, UMBridgeModel
from torchshm.forward import UMBridgeError
from torchshm.storage import evaluate
from umbridge_served import LOADS, X, strains

HERE = Path(__file__).parent
TRUTH = np.array([40.0, -25.0])


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


@pytest.fixture(scope="module")
def server() -> Iterator[str]:
    """``umbridge_served.py`` on 127.0.0.1 and a free port; stopped at the end."""
    port = _free_port()
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(HERE.parents[1]), os.environ.get("PYTHONPATH", "")]))
    process = subprocess.Popen([sys.executable, str(HERE / "umbridge_served.py"), str(port)], env=env,
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 30.0
    try:
        while True:
            try:
                requests.get(f"{url}/Info", timeout=1.0)
                break
            except requests.ConnectionError:
                if process.poll() is not None or time.monotonic() > deadline:
                    raise RuntimeError(f"UM-Bridge server did not start: {process.stdout.read()!r}")
                time.sleep(0.1)
        yield url
    finally:
        process.terminate()
        process.wait(timeout=10)


def test_strains_identity_and_refusals(server: str) -> None:
    linear = UMBridgeModel(server, "linear", X, LOADS, names=["a", "b"], timeout=10.0)
    served = UMBridgeModel(server, "served", X, LOADS, timeout=10.0)
    theta = torch.tensor([[1.0, 2.0], [3.0, -1.0]])
    expected = np.stack([strains(row) for row in theta.numpy()])
    assert np.allclose(linear(theta).numpy(), expected, rtol=0, atol=1e-12)
    assert np.allclose(served(theta).numpy(), expected, rtol=0, atol=1e-12)
    assert served.names == ["theta_0", "theta_1"] and linear.identity != served.identity
    assert UMBridgeModel(server, "linear", X, LOADS).identity == linear.identity
    with pytest.raises(ValueError, match="expected \\[60\\]"):
        UMBridgeModel(server, "linear", X[:-1], LOADS)
    with pytest.raises(ValueError, match="not supported by server"):
        UMBridgeModel(server, "nosuch", X, LOADS)
    with pytest.raises(ValueError, match="takes 2 parameters"):
        UMBridgeModel(server, "linear", X, LOADS, names=["a"])
    with pytest.raises(ValueError, match="cannot reach"):
        UMBridgeModel(f"http://127.0.0.1:{_free_port()}", "linear", X, LOADS)


def test_store_keeps_runs_under_the_identity(server: str, tmp_path: Path) -> None:
    design = np.array([[1.0, 2.0], [3.0, -1.0], [1.0, 2.0]])
    first = evaluate(UMBridgeModel(server, "linear", X, LOADS), design, store=tmp_path / "s.sqlite")
    again = evaluate(UMBridgeModel(server, "linear", X, LOADS), design, store=tmp_path / "s.sqlite")
    assert (first.n_new, again.n_new, again.n_reused) == (2, 0, 2)
    assert np.array_equal(first.outputs, again.outputs) and again.ok.all()


def test_a_server_error_or_a_timeout_is_a_failed_run(server: str) -> None:
    model = UMBridgeModel(server, "linear", X, LOADS, timeout=10.0)
    with pytest.raises(UMBridgeError, match="InvalidInput"):
        model.run(np.array([1.0, 2.0, 3.0]))
    slow = UMBridgeModel(server, "linear", X, LOADS, config={"sleep": 1.5}, timeout=0.3)
    result = evaluate(slow, np.array([[1.0, 2.0]]))
    assert not result.ok[0] and "no answer within" in result.errors[0]


@pytest.mark.filterwarnings("ignore:emcee. the chain after burn-in:RuntimeWarning")
@pytest.mark.slow
def test_identification_through_umbridge(server: str) -> None:
    """A linear-Gaussian problem (independent discrepancy, σm = 0): emcee's posterior mean
    matches the exact one to 0.3 posterior sd."""
    model = UMBridgeModel(server, "linear", X, LOADS, names=["a", "b"], timeout=10.0)
    rng = np.random.default_rng(0)
    sigma_e, sigma_a = 0.5, 0.5
    y = strains(TRUTH) + np.hypot(sigma_a, sigma_e) * rng.standard_normal((len(LOADS), len(X)))
    priors = {"a": Normal(30.0, 20.0), "b": Normal(0.0, 20.0), "sigma_a": sigma_a}
    problem = Problem(model, Measurements(X, y, LOADS, sigma_e=sigma_e), kernel="independent",
                      priors=priors, sigma_m=0.0)
    post = torchshm.identify(problem, method="emcee", seed=0, n_walkers=8, n_steps=120)

    A = np.stack([strains(e).ravel() for e in np.eye(2)], axis=1)  # (L n) x P
    s2 = sigma_a**2 + sigma_e**2
    cov = np.linalg.inv(np.diag([1 / 20.0**2] * 2) + A.T @ A / s2)
    mean = cov @ (np.array([30.0, 0.0]) / 20.0**2 + A.T @ y.ravel() / s2)
    sd = np.sqrt(np.diag(cov))
    samples = np.asarray(post.samples)
    assert np.all(np.abs(samples.mean(0) - mean) < 0.3 * sd), (samples.mean(0), mean, sd)
    assert problem.n_model_evaluations == post.n_model_evaluations > 0

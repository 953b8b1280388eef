"""Numerical failures inside PyVBMC and emcee: recovered from, or one clear error, never a raw
traceback from the peer library."""

from __future__ import annotations

import warnings

import emcee
import numpy as np
import pytest
import pyvbmc.vbmc.vbmc as pyvbmc_module

import torchshm
from torchshm.inference.peer_errors import PeerNumericalError, peer_of

from noisy_models import bending_problem


def _failing(original, times: int):  # type: ignore[no-untyped-def]
    """``original`` raising numpy's ``Singular matrix`` on its first ``times`` calls."""
    calls = {"n": 0}

    def wrapper(*args, **kwargs):  # type: ignore[no-untyped-def]
        calls["n"] += 1
        if calls["n"] <= times:
            raise np.linalg.LinAlgError("Singular matrix")
        return original(*args, **kwargs)

    return wrapper


@pytest.mark.slow
@pytest.mark.parametrize("method, options", [
    ("vbmc", {"max_fun_evals": 40}), ("emcee", {"n_walkers": 12, "n_steps": 300}),
])
def test_sigma_m_zero_on_nearly_noiseless_data_is_right_or_one_clear_error(method, options) -> None:
    problem = bending_problem(sigma_m_data=0.0, sigma_m=0.0, sigma_e=0.05)  # truth E = 32
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # small budgets: NOT CONVERGED
            post = torchshm.identify(problem, method=method, seed=0, **options)
    except PeerNumericalError as err:
        assert "sigma_m" in str(err) and "\n" not in str(err)
        return
    row = post.summary()["E"]
    assert abs(row.mean - 32.0) < 0.5 and row.q2_5 < 32.0 < row.q97_5


@pytest.mark.slow
def test_vbmc_restarts_once_from_the_evaluated_points_after_a_failure_inside_pyvbmc(monkeypatch) -> None:
    monkeypatch.setattr(pyvbmc_module, "train_gp", _failing(pyvbmc_module.train_gp, times=1))
    problem = bending_problem(sigma_m_data=0.05)
    with pytest.warns(RuntimeWarning, match="PyVBMC failed numerically .*Singular matrix.*restarting"):
        post = torchshm.identify(problem, method="vbmc", seed=0, max_fun_evals=40)
    assert post.diagnostics["n_numerical_restarts"] == 1
    assert abs(post.summary()["E"].mean - 32.0) < 2.0


def test_vbmc_failing_twice_stops_with_one_line_naming_cause_and_change(monkeypatch) -> None:
    monkeypatch.setattr(pyvbmc_module, "train_gp", _failing(pyvbmc_module.train_gp, times=99))
    problem = bending_problem(sigma_m_data=0.0, sigma_m=0.0)
    with pytest.warns(RuntimeWarning, match="restarting"), \
            pytest.raises(PeerNumericalError, match="failed numerically twice") as info:
        torchshm.identify(problem, method="vbmc", seed=0, max_fun_evals=40)
    message = str(info.value)
    assert "LinAlgError: Singular matrix" in message and "sigma_m > 0" in message
    assert "\n" not in message and info.value.__suppress_context__


def test_emcee_failing_inside_its_move_stops_with_one_clear_error(monkeypatch) -> None:
    move = emcee.moves.red_blue.RedBlueMove
    monkeypatch.setattr(move, "propose", _failing(move.propose, times=99))
    problem = bending_problem(sigma_m_data=0.05)
    with pytest.raises(PeerNumericalError, match=r"emcee failed \(LinAlgError: Singular matrix"):
        torchshm.identify(problem, method="emcee", seed=0, n_walkers=12, n_steps=20)


def test_errors_of_torchshm_or_of_the_caller_are_not_disguised() -> None:
    try:
        torchshm.Uniform(2.0, 1.0)  # torchshm's own ValueError
    except ValueError as err:
        assert peer_of(err) is None
    try:
        np.linalg.inv(np.zeros((2, 2)))  # numpy called from here: looked through, no peer
    except np.linalg.LinAlgError as err:
        assert peer_of(err) is None

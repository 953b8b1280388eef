"""Failing model runs are recorded, reported and not retried unless asked."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch
from storage_models import GridModel, grid, read_counter, strain_function

from torchshm.storage import EvaluationStore, evaluate, theta_key
from torchshm.storage.record import run_model

FAIL = {(10.0, 4.0): "raise", (40.0, 0.0): "nan", (70.0, 12.0): "shape", (100.0, 8.0): "inf"}


@pytest.fixture
def theta() -> np.ndarray:
    return grid(4, 4)  # E_c in {10, 40, 70, 100}, log10_K_r in {0, 4, 8, 12}


def test_failures_do_not_abort_and_are_stored(tmp_path: Path, theta: np.ndarray) -> None:
    store, counter = EvaluationStore(tmp_path / "s.sqlite"), str(tmp_path / "calls.txt")
    model = GridModel(counter=counter, fail=FAIL)
    result = evaluate(model, theta, store=store)

    failed_rows = [i for i, row in enumerate(theta) if tuple(row) in FAIL]
    assert np.flatnonzero(~result.ok).tolist() == failed_rows
    assert np.isnan(result.outputs[failed_rows]).all()
    for i in np.flatnonzero(result.ok):
        expected = strain_function(torch.as_tensor(theta[i]), model.x, model.loads).numpy()
        np.testing.assert_allclose(result.outputs[i], expected, rtol=1e-14, atol=0)
    errors = {tuple(theta[i]): result.errors[i] for i in failed_rows}
    assert errors[(10.0, 4.0)] == "RuntimeError: solver diverged at E_c=10"
    assert "1 NaN and 0 inf" in errors[(40.0, 0.0)]
    assert "shape (3, 6), expected (L, n) = (3, 7)" in errors[(70.0, 12.0)]
    assert "0 NaN and 1 inf" in errors[(100.0, 8.0)]

    failed_theta, failed_errors = store.failures(model)
    assert {tuple(row): e for row, e in zip(failed_theta.tolist(), failed_errors)} == errors
    assert store.count(model, status="failed") == 4 and store.count(model, status="ok") == 12
    summary = result.summary()
    assert "12 ok, 4 failed" in summary and "16 new model runs" in summary
    for error in errors.values():
        assert error in summary


def test_failures_not_retried_unless_asked(tmp_path: Path, theta: np.ndarray) -> None:
    store, counter = EvaluationStore(tmp_path / "s.sqlite"), str(tmp_path / "calls.txt")
    evaluate(GridModel(counter=counter, fail=FAIL), theta, store=store)
    n_calls = len(read_counter(counter))

    again = evaluate(GridModel(counter=counter, fail=FAIL), theta, store=store)
    assert again.n_new == 0 and len(read_counter(counter)) == n_calls
    assert again.n_failed == 4 and "4 failed" in again.summary()

    fixed = GridModel(counter=counter)  # same identity, the cause of the failures removed
    retried = evaluate(fixed, theta, store=store, retry_failed=True)
    new_calls = [key for what, key, _ in read_counter(counter)[n_calls:] if what == "start"]
    assert retried.n_new == 4 and len(new_calls) == 4
    assert sorted(new_calls) == sorted(f"{e:.12g},{k:.12g}" for e, k in FAIL)
    assert retried.ok.all() and store.count(fixed, status="failed") == 0
    reference = evaluate(GridModel(), theta)
    assert np.array_equal(retried.outputs, reference.outputs)


def test_ok_evaluation_is_never_replaced_by_a_failure(tmp_path: Path) -> None:
    store, model = EvaluationStore(tmp_path / "s.sqlite"), GridModel(fail=FAIL)
    key, theta = theta_key(np.array([40.0, 0.0])), np.array([40.0, 0.0])
    failed = run_model(model, model.identity, key, theta, (3, 7))
    good = run_model(GridModel(), model.identity, key, theta, (3, 7))
    assert not failed.ok and good.ok
    assert store.put(failed)  # a failure is stored ...
    assert store.put(good)  # ... and replaced by a later success,
    assert not store.put(failed)  # which a later failure never replaces
    assert store.count(model, status="ok") == 1 and store.count(model) == 1
    assert np.array_equal(store.all(model)[1][0], good.outputs)


def test_duplicate_rows_are_evaluated_once(tmp_path: Path) -> None:
    counter = str(tmp_path / "calls.txt")
    theta = np.array([[20.0, 1.0], [30.0, 2.0], [20.0, 1.0 + 1e-14], [20.0, 1.0]])
    result = evaluate(GridModel(counter=counter), theta)
    assert result.n_new == 2 and len([c for c in read_counter(counter) if c[0] == "start"]) == 2
    assert np.array_equal(result.outputs[0], result.outputs[2])
    assert np.array_equal(result.outputs[0], result.outputs[3])

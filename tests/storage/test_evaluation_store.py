"""The SQLite evaluation store: keys, round trips, damaged values, spool files, bad input."""

from __future__ import annotations

import pickle
import sqlite3
from pathlib import Path

import numpy as np
import pytest
import torch
from storage_models import GridModel, grid

from torchshm.storage import EvaluationStore, canonical_theta, evaluate, theta_key
from torchshm.storage.record import run_model


def test_canonical_theta_rounds_to_12_significant_digits() -> None:
    theta = canonical_theta(torch.tensor([[1.0 / 3.0, -0.0], [1.0 / 3.0 + 1e-15, 2e-300]]))
    assert theta.dtype == np.float64 and theta.shape == (2, 2)
    assert theta[0, 0] == 0.333333333333 and np.signbit(theta[0, 1]) == False  # noqa: E712
    assert theta_key(theta[0]) == theta_key(theta[1][:1].tolist() + [0.0]) == (
        "3.33333333333e-01,0.00000000000e+00"
    )
    assert canonical_theta([35.0, 6.0]).shape == (1, 2)
    assert theta_key(canonical_theta([123456.7890123456])[0]) == "1.23456789012e+05"


@pytest.mark.parametrize(
    ("theta", "message"),
    [
        ([[1.0, np.nan]], "theta_p row 0 is not finite"),
        ([[1.0, 2.0], [np.inf, 1.0]], "theta_p row 1 is not finite"),
        (np.zeros((2, 2, 2)), r"theta_p must have shape \(N, P\) or \(P,\)"),
        (np.zeros((3, 0)), "theta_p has no parameters"),
        ([["a", "b"]], "theta_p is not an array of numbers"),
    ],
)
def test_bad_theta_is_a_one_line_error(theta: object, message: str) -> None:
    with pytest.raises(ValueError, match=message) as info:
        evaluate(GridModel(), theta)
    assert "\n" not in str(info.value)


def test_round_trip_is_exact_and_keeps_metadata(tmp_path: Path) -> None:
    store, model = EvaluationStore(tmp_path / "s.sqlite"), GridModel()
    theta = grid(3, 3) * (1.0 + 1e-9 * np.arange(9))[:, None]
    first = evaluate(model, theta, store=store)
    again = evaluate(model, theta, store=EvaluationStore(tmp_path / "s.sqlite"))
    assert again.n_new == 0 and again.n_reused == 9
    assert np.array_equal(again.outputs, first.outputs)
    assert np.array_equal(again.theta_p, first.theta_p)
    stored_theta, stored = store.all(model)
    assert stored.shape == (9, 3, 7) and np.array_equal(stored_theta, canonical_theta(theta))
    record = store.records(model)[0]
    assert record.ok and record.host and record.pid > 0 and record.wall_time >= 0.0
    assert record.finished_at.endswith("+00:00") and record.model == "grid-model-v1"
    assert store.models() == ["grid-model-v1"] and store.count() == 9


def test_empty_batch_and_bad_n_jobs(tmp_path: Path) -> None:
    result = evaluate(GridModel(), np.empty((0, 2)), store=tmp_path / "s.sqlite")
    assert result.outputs.shape == (0, 3, 7) and result.n_new == 0
    with pytest.raises(ValueError, match="n_jobs must be a non-zero integer, got 0"):
        evaluate(GridModel(), [[1.0, 2.0]], n_jobs=0)


def test_store_is_empty_for_an_unknown_model(tmp_path: Path) -> None:
    store = EvaluationStore(tmp_path / "s.sqlite")
    theta, outputs = store.all(GridModel())
    assert theta.shape == (0, 0) and outputs.shape == (0, 3, 7)
    assert store.failures(GridModel())[1] == [] and store.count(GridModel()) == 0


def test_damaged_value_is_never_read_as_valid(tmp_path: Path) -> None:
    store, model = EvaluationStore(tmp_path / "s.sqlite"), GridModel()
    theta = grid(2, 2)
    good = evaluate(model, theta, store=store)
    with sqlite3.connect(store.path) as con:  # flip one byte, truncate another value
        rows = con.execute("SELECT theta_key, outputs FROM evaluations ORDER BY rowid").fetchall()
        flipped = bytearray(rows[0][1])
        flipped[13] ^= 0x01
        update = "UPDATE evaluations SET outputs = ? WHERE theta_key = ?"
        con.execute(update, (bytes(flipped), rows[0][0]))
        con.execute(update, (rows[1][1][:-8], rows[1][0]))
    assert len(store.records(model)) == 2  # the damaged two are skipped
    again = evaluate(model, theta, store=store)
    assert again.n_new == 2 and again.n_reused == 2  # the damaged ones ran again
    assert np.array_equal(again.outputs, good.outputs) and len(store.records(model)) == 4


def test_spool_files_are_ingested_and_damaged_ones_rejected(tmp_path: Path) -> None:
    store, model = EvaluationStore(tmp_path / "s.sqlite"), GridModel()
    key = theta_key(np.array([20.0, 1.0]))
    record = run_model(model, model.identity, key, np.array([20.0, 1.0]), (3, 7))
    path = store.deposit(record)
    (store.spool_folder / ".tmp-partial.npz").write_bytes(b"PK\x03\x04 half a file")
    (store.spool_folder / "damaged.npz").write_bytes(path.read_bytes()[:-40])
    result = evaluate(model, [[20.0, 1.0]], store=store)  # e.g. the submitting process had died
    assert result.n_new == 0 and np.array_equal(result.outputs[0], record.outputs)
    assert not path.exists() and (store.spool_folder / "rejected" / "damaged.npz").exists()
    assert (store.spool_folder / ".tmp-partial.npz").exists()  # never taken for a result


def test_store_pickles_as_a_path(tmp_path: Path) -> None:
    store = EvaluationStore(tmp_path / "sub" / "s.sqlite")
    copy = pickle.loads(pickle.dumps(store))
    assert copy.path == store.path and copy.count() == 0


def test_bad_store_path_is_a_one_line_error(tmp_path: Path) -> None:
    (tmp_path / "notes.txt").write_text("not a database " * 100)
    with pytest.raises(ValueError, match="is not an evaluation store") as info:
        EvaluationStore(tmp_path / "notes.txt")
    assert "\n" not in str(info.value)
    with pytest.raises(ValueError, match="is a folder, not a file"):
        EvaluationStore(tmp_path)


def test_model_without_sensor_positions_is_rejected() -> None:
    with pytest.raises(ValueError, match="has no attribute 'x'"):
        evaluate(lambda theta: theta, [[1.0, 2.0]])


def test_a_store_write_failure_keeps_the_run_in_the_spool(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    store, model = EvaluationStore(tmp_path / "s.sqlite"), GridModel()
    put, failures = store.put, [sqlite3.OperationalError("database is locked")] * 2

    def flaky_put(record):
        if failures:
            raise failures.pop()
        return put(record)

    monkeypatch.setattr(store, "put", flaky_put)
    result = evaluate(model, grid(3, 1), store=store)
    assert result.ok.all() and result.n_new == 3
    assert store.count(model) == 3 and not list(store.spool_folder.glob("*.npz"))
    again = evaluate(model, grid(3, 1), store=tmp_path / "s.sqlite")
    assert again.n_new == 0 and np.array_equal(again.outputs, result.outputs)

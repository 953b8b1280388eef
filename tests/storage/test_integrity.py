"""The store's integrity check finds a damaged row, an unreadable spool file and a damaged file."""

from __future__ import annotations

import sqlite3
from pathlib import Path

import pytest
from storage_models import GridModel, grid

from torchshm.storage import EvaluationStore, evaluate
from torchshm.storage.integrity import check_store, main


def _store(tmp_path: Path) -> EvaluationStore:
    store = EvaluationStore(tmp_path / "store.sqlite")
    evaluate(GridModel(), grid(2, 2), store=store)
    return store


def test_sound_store_passes(tmp_path: Path) -> None:
    report = _store(tmp_path).check()
    assert report.ok and report.failures == 0
    assert report.sqlite == ["ok"] and report.n_rows == report.n_ok == 4
    assert "sound" in report.summary()


def test_damaged_row_is_reported_and_kept(tmp_path: Path) -> None:
    store = _store(tmp_path)
    with sqlite3.connect(store.path) as con:
        con.execute("UPDATE evaluations SET outputs = zeroblob(length(outputs)) WHERE rowid = 2")
    report = store.check()
    assert not report.ok and report.failures == 1 and len(report.bad_rows) == 1
    assert report.n_rows == 4 and report.n_ok == 3
    assert check_store(store.path).n_rows == 4  # the check only reads: the row is still there


def test_unreadable_spool_file_is_reported(tmp_path: Path) -> None:
    store = _store(tmp_path)
    store.spool_folder.mkdir()
    (store.spool_folder / "0123-abc.npz").write_bytes(b"not an npz file")
    (store.spool_folder / ".tmp-0123-def.npz").write_bytes(b"half")
    report = store.check()
    assert report.spool_unreadable == ["0123-abc.npz"] and report.spool_partial == 1
    assert not report.ok


def test_file_that_is_not_a_database(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "store.sqlite"
    path.write_bytes(b"garbage" * 1000)
    report = check_store(path)
    assert not report.ok and "not a readable evaluation store" in report.sqlite[0]
    assert main([str(path), str(tmp_path / "missing.sqlite")]) == 1
    out = capsys.readouterr()
    assert out.out.count("\n") == 1 and "DAMAGED" in out.out and "missing.sqlite" in out.err

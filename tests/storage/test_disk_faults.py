"""A full disk, a read-only folder and a damaged store file: one line naming the file, and every
run stored before is kept.

The full disk is a 256 KiB tmpfs (run when this process may mount one: root on Linux). A
per-process file size limit (``RLIMIT_FSIZE``, writes past it fail with ``EFBIG``) is tried
too, everywhere: there only the growing SQLite file fails, so every finished run must wait in
the spool for a later ingest.
"""

from __future__ import annotations

import os
import sqlite3
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from storage_models import GridModel, grid

from torchshm.storage import EvaluationStore, evaluate
from torchshm.storage.integrity import check_store

HERE = Path(__file__).parent

FILL = """
import resource, signal, sys
import numpy as np, torch
from torchshm.storage import evaluate

class Big:
    identity = "big-v1"
    x, loads = torch.arange(500.0, dtype=torch.float64), torch.arange(4.0, dtype=torch.float64)
    def __call__(self, theta):
        return torch.ones(4, 500, dtype=torch.float64) * theta.sum()

if len(sys.argv) > 2:  # a file size limit instead of a small file system
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (int(sys.argv[2]), int(sys.argv[2])))
try:
    evaluate(Big(), np.stack([np.arange(60.0), np.ones(60)], 1), store=sys.argv[1])
except OSError as exc:
    print(exc, file=sys.stderr)
    sys.exit(2)
"""


def _mount(folder: Path, *options: str) -> bool:
    folder.mkdir(parents=True, exist_ok=True)
    if os.geteuid() != 0 or not sys.platform.startswith("linux"):
        return False
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", ",".join(options), "tmpfs", str(folder)],
                          capture_output=True)
    return done.returncode == 0


@pytest.fixture(params=["tmpfs", "rlimit"])
def small_disk(tmp_path: Path, request: pytest.FixtureRequest) -> Iterator[tuple[Path, list[str]]]:
    folder = tmp_path / "disk"
    mounted = request.param == "tmpfs" and _mount(folder, "size=256k")
    if request.param == "tmpfs" and not mounted:
        pytest.skip("cannot mount a small tmpfs here (needs root on Linux)")
    folder.mkdir(parents=True, exist_ok=True)
    yield folder, ([] if mounted else [str(200 * 1024)])
    if mounted:
        subprocess.run(["umount", str(folder)], check=True)


def test_full_disk_ends_in_one_line_and_keeps_stored_runs(small_disk: tuple[Path, list[str]]) -> None:
    folder, limit = small_disk
    store = folder / "store.sqlite"
    done = subprocess.run([sys.executable, "-c", FILL, str(store), *limit], capture_output=True,
                          text=True, env=dict(os.environ, OMP_NUM_THREADS="1"), timeout=300)
    report = check_store(store)
    assert report.ok and report.n_ok >= 3  # every committed run is intact
    assert report.spool_partial == 0  # a failed spool write leaves nothing behind
    if limit:  # only the store file hits the size limit: every run waits in the spool
        assert done.returncode == 0, done.stderr
        assert report.n_ok < 60 and report.n_ok + report.spool_pending == 60
        return
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and str(store) in lines[0] and "cannot keep the run" in lines[0]
    assert report.n_ok < 60


def test_read_only_folder_is_named_and_the_store_is_untouched(tmp_path: Path) -> None:
    folder = tmp_path / "ro"
    mounted = _mount(folder, "size=4m")
    if not mounted and os.geteuid() == 0:
        pytest.skip("cannot make a read-only folder here (root without mount)")
    store = folder / "store.sqlite"
    evaluate(GridModel(), grid(2, 2), store=store)
    if mounted:
        subprocess.run(["mount", "-o", "remount,ro", str(folder)], check=True)
    else:
        folder.chmod(0o555)
        for name in ("store.sqlite-wal", "store.sqlite-shm"):
            (folder / name).unlink(missing_ok=True)
    try:
        with pytest.raises(ValueError, match="read-only") as error:
            evaluate(GridModel(), grid(3, 2), store=store)
        assert str(store) in str(error.value) and "\n" not in str(error.value)
    finally:
        if mounted:
            subprocess.run(["mount", "-o", "remount,rw", str(folder)], check=True)
        else:
            folder.chmod(0o755)
    assert EvaluationStore(store).count() == 4 and check_store(store).ok
    if mounted:
        subprocess.run(["umount", str(folder)], check=True)


def test_truncated_store_is_refused_in_one_line(tmp_path: Path) -> None:
    path = tmp_path / "store.sqlite"
    evaluate(GridModel(), grid(5, 4), store=path)
    with sqlite3.connect(path) as con:
        con.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    size = path.stat().st_size
    with open(path, "r+b") as handle:
        handle.truncate(size // 2)
    with pytest.raises(ValueError, match="malformed|not a database") as error:
        EvaluationStore(path)
    assert str(path) in str(error.value) and "\n" not in str(error.value)
    assert path.stat().st_size == size // 2  # left as it is for recovery, never overwritten


def test_garbage_store_is_refused_in_one_line(tmp_path: Path) -> None:
    path = tmp_path / "store.sqlite"
    path.write_bytes(os.urandom(8192))
    with pytest.raises(ValueError, match="not an evaluation store") as error:
        evaluate(GridModel(), grid(2, 2), store=path)
    assert str(path) in str(error.value) and "\n" not in str(error.value)

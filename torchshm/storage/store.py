"""Durable store of forward-model evaluations in one SQLite file.

Why SQLite. A finite element run can take ten minutes, so a finished run must survive any
crash of the process that asked for it, and several processes (joblib workers, two studies
started at once) must be able to add runs to one store without losing any. SQLite gives
exactly this from the Python standard library, in one file a user can copy or inspect:

* each evaluation is committed in its own transaction as soon as it finishes, with
  ``synchronous=FULL``; a process killed mid-write leaves the previous committed state, never
  half a row;
* write-ahead logging (WAL) lets readers run while one process writes, and a busy timeout
  makes concurrent writers wait for each other instead of failing;
* outputs are a float64 BLOB with shape columns and a SHA-256 checksum over key, shape and
  bytes, so a damaged value is detected on read and re-evaluated, never used.

A store holds any number of models, keyed by ``model_identity(model)``, and parameter
vectors, keyed by their canonical text (12 significant digits, see :mod:`.keys`).

Network file systems. WAL needs shared memory between the processes using the file, so all
processes that open the store must run on one machine, and the file must be on a local disk
or a file system with working POSIX locks. Workers on other cluster nodes (submitit/Slurm)
therefore never open the SQLite file: they deposit each result as its own file in the spool
folder beside it (``<path>.spool/``, written to a temporary name and renamed, which is atomic
on NFS as well), and the submitting process moves those files into the store
(:meth:`EvaluationStore.ingest`). A result deposited after the submitting process died is
picked up by the next run on the same store.
"""

from __future__ import annotations

import contextlib
import logging
import os
import sqlite3
import time
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np

from torchshm.forward.protocol import model_identity, output_shape
from torchshm.storage import spool
from torchshm.storage.integrity import IntegrityReport, check_store
from torchshm.storage.keys import key_theta
from torchshm.storage.record import Record
from torchshm.storage.rows import COLUMNS, SCHEMA, SCHEMA_VERSION, UPSERT, row_record


logger = logging.getLogger(__name__)


class EvaluationStore:
    """Evaluations of forward models, persisted in a SQLite file as soon as they finish.

    The object holds only the path (a connection is opened per operation), so it can be
    pickled to worker processes, which open the store themselves.

    Args:
        path: the SQLite file; created with its parent folders if absent.
        timeout: seconds a writer waits for another process's transaction.

    Raises:
        ValueError: if ``path`` exists but is not an evaluation store.
    """

    def __init__(self, path: str | Path, timeout: float = 120.0) -> None:
        self.path = Path(path).expanduser().resolve()
        self.timeout = float(timeout)
        if self.path.is_dir():
            raise ValueError(f"evaluation store {self.path} is a folder, not a file")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._initialise()

    @property
    def spool_folder(self) -> Path:
        """Folder in which remote workers deposit results (``<path>.spool``)."""
        return self.path.with_name(self.path.name + ".spool")

    def __repr__(self) -> str:
        return f"EvaluationStore({str(self.path)!r})"

    @contextlib.contextmanager
    def _connect(self) -> Iterator[sqlite3.Connection]:
        con = sqlite3.connect(self.path, timeout=self.timeout, isolation_level=None)
        try:
            con.execute("PRAGMA synchronous = FULL")
            yield con
        finally:
            con.close()

    def _initialise(self) -> None:
        for attempt in range(20):
            try:
                with self._connect() as con:
                    mode = con.execute("PRAGMA journal_mode = WAL").fetchone()[0]
                    if str(mode).lower() != "wal":
                        logger.warning("%s: WAL not available, using journal mode %s", self, mode)
                    con.executescript(f"BEGIN IMMEDIATE; {SCHEMA} COMMIT;")
                    version = con.execute(
                        "SELECT value FROM meta WHERE name = 'schema_version'"
                    ).fetchone()[0]
                break
            except sqlite3.OperationalError as exc:  # another process is creating the file
                if "locked" not in str(exc) or attempt == 19:
                    if not os.access(self.path.parent, os.W_OK):
                        exc = "its folder is read-only (SQLite writes its journal beside the " \
                              "file); copy the store to a writable folder"  # type: ignore[assignment]
                    raise ValueError(f"cannot open evaluation store {self.path}: {exc}") from None
                time.sleep(0.05 * (attempt + 1))
            except sqlite3.DatabaseError as exc:
                raise ValueError(f"{self.path} is not an evaluation store: {exc}") from None
        if version != SCHEMA_VERSION:
            raise ValueError(
                f"{self.path}: store schema version {version}, expected {SCHEMA_VERSION}"
            )

    def put(self, record: Record) -> bool:
        """Commit one evaluation in its own transaction.

        Returns:
            True if written; False if the store already held a successful evaluation of this
            model and θp (that one is kept).
        """
        outputs = record.outputs
        shape = (None, None) if outputs is None else outputs.shape
        blob = None if outputs is None else np.ascontiguousarray(outputs, dtype="<f8").tobytes()
        row = (
            record.model, record.key, record.status, blob, shape[0], shape[1], record.checksum,
            record.error, record.wall_time, record.finished_at, record.host, record.pid,
            record.traceback,
        )
        with self._connect() as con:
            con.execute("BEGIN IMMEDIATE")
            written = con.execute(UPSERT, row).rowcount
            con.execute("COMMIT")
        return written > 0

    def save(self, record: Record) -> None:
        """Commit a record; if the SQLite file cannot be written, deposit it in the spool.

        A finished run is never lost to a locked or unwritable store file: a spool file is
        moved into the store by the next :meth:`ingest`.

        Raises:
            OSError: when neither the file nor the spool can be written (disk full, read-only
                folder); one line naming the store. Every run stored before is kept.
        """
        try:
            self.put(record)
        except sqlite3.Error as exc:
            try:
                path = self.deposit(record)
            except OSError as err:
                raise OSError(
                    err.errno,
                    f"evaluation store {self.path}: cannot keep the run just finished ({exc}; "
                    f"spool: {err.strerror}); every run stored before is kept: free space or "
                    f"make the folder writable, then run again",
                ) from None
            logger.warning("%s: cannot write (%s); result kept in %s", self, exc, path)

    def lookup(self, model: object, keys: Sequence[str]) -> dict[str, Record]:
        """Stored evaluations of a model at canonical keys (see :func:`theta_key`).

        A row whose checksum does not match its content is deleted (with a warning) and left
        out, so that it is evaluated again.

        Args:
            model: a forward model or its identity string.
            keys: canonical θp keys.

        Returns:
            key -> record, for the keys the store holds.
        """
        identity = _identity(model)
        found: dict[str, Record] = {}
        with self._connect() as con:
            for start in range(0, len(keys), 500):
                chunk = list(keys[start : start + 500])
                query = (
                    f"SELECT {COLUMNS} FROM evaluations WHERE model = ? "
                    f"AND theta_key IN ({', '.join('?' * len(chunk))})"
                )
                for row in con.execute(query, [identity, *chunk]).fetchall():
                    record = row_record(row)
                    if record is None:
                        self._drop_corrupt(con, row)
                    else:
                        found[record.key] = record
        return found

    def records(self, model: object, status: str | None = None) -> list[Record]:
        """Every valid stored evaluation of a model, oldest first, optionally by status."""
        self.ingest()
        query = f"SELECT {COLUMNS} FROM evaluations WHERE model = ?"
        params: list[object] = [_identity(model)]
        if status is not None:
            query, params = query + " AND status = ?", [*params, status]
        with self._connect() as con:
            rows = con.execute(query + " ORDER BY rowid", params).fetchall()
        records = [row_record(row) for row in rows]
        if None in records:
            logger.warning("%s: %d corrupt evaluations skipped", self, records.count(None))
        return [record for record in records if record is not None]

    def all(self, model: object) -> tuple[np.ndarray, np.ndarray]:
        """Every successful evaluation of a model, oldest first.

        Args:
            model: a forward model or its identity string.

        Returns:
            ``(theta_p, outputs)``: canonical parameters `M x P` and strains [µε]
            `M x L x n`. With none stored, `0 x 0` and `0 x L x n` (`0 x 0 x 0` when
            ``model`` is an identity string).
        """
        records = self.records(model, status="ok")
        if not records:
            shape = (0, 0) if isinstance(model, str) else output_shape(model)
            return np.empty((0, 0)), np.empty((0, *shape))
        theta = np.stack([key_theta(record.key) for record in records])
        return theta, np.stack([record.outputs for record in records])

    def failures(self, model: object) -> tuple[np.ndarray, list[str]]:
        """Failed evaluations of a model: parameters `F x P` and their error texts."""
        records = self.records(model, status="failed")
        theta = np.stack([key_theta(r.key) for r in records]) if records else np.empty((0, 0))
        return theta, [str(record.error) for record in records]

    def count(self, model: object | None = None, status: str | None = None) -> int:
        """Number of stored evaluations, of one model or all, optionally by status."""
        self.ingest()
        query, params = "SELECT COUNT(*) FROM evaluations WHERE 1", []
        if model is not None:
            query, params = query + " AND model = ?", [_identity(model)]
        if status is not None:
            query, params = query + " AND status = ?", [*params, status]
        with self._connect() as con:
            return int(con.execute(query, params).fetchone()[0])

    def models(self) -> list[str]:
        """Identities of the models with stored evaluations."""
        with self._connect() as con:
            return [row[0] for row in con.execute("SELECT DISTINCT model FROM evaluations")]

    def check(self) -> IntegrityReport:
        """Integrity check of the file, every row's checksum and the spool (read only); see
        :func:`torchshm.storage.integrity.check_store`."""
        return check_store(self.path)

    def deposit(self, record: Record) -> Path:
        """Write a record to the spool folder (safe from any host); see :meth:`ingest`."""
        return spool.deposit(self.spool_folder, record)

    def ingest(self) -> int:
        """Move every deposited result from the spool folder into the store.

        Returns:
            The number of spool files moved. When the SQLite file cannot be written (disk
            full), the rest stay in the spool, with a warning, for a later ingest.
        """
        try:
            return spool.ingest(self.spool_folder, self.put)
        except sqlite3.Error as exc:
            logger.warning("%s: cannot move results from the spool (%s); they stay in %s",
                           self, exc, self.spool_folder)
            return 0

    def _drop_corrupt(self, con: sqlite3.Connection, row: tuple) -> None:
        logger.warning("%s: evaluation %s of %s is corrupt and is dropped", self, row[1], row[0])
        con.execute("BEGIN IMMEDIATE")
        con.execute(
            "DELETE FROM evaluations WHERE model = ? AND theta_key = ? AND checksum = ?",
            (row[0], row[1], row[6]),
        )
        con.execute("COMMIT")


def _identity(model: object) -> str:
    return model if isinstance(model, str) else model_identity(model)


"""Integrity check of an evaluation store: the SQLite file, every row's checksum, the spool.

:func:`check_store` reads a store without changing it (a damaged row is reported, not
dropped) and answers whether every finished evaluation it holds is intact and whether every
result deposited in its spool folder can still be ingested. It is what the fault-injection
script (``scripts/fault_injection.py``) runs after each kill, and what a user can run on a
store copied from a cluster (``python -m torchshm.storage.integrity STORE``).
"""

from __future__ import annotations

import sqlite3
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from torchshm.storage import spool
from torchshm.storage.rows import COLUMNS, row_record


@dataclass
class IntegrityReport:
    """Outcome of :func:`check_store`.

    Attributes:
        path: the SQLite file.
        sqlite: the lines of SQLite's ``PRAGMA integrity_check`` (``["ok"]`` when sound).
        n_rows: stored evaluations (ok and failed).
        n_ok: stored successful evaluations.
        bad_rows: ``(model, θp key)`` of rows whose checksum does not match their content.
        spool_pending: complete spool files not ingested yet (each must be readable).
        spool_unreadable: names of spool files that fail to read or fail their checksum.
        spool_rejected: files an earlier ingest moved to ``rejected/``.
        spool_partial: ``.tmp-`` files left by a writer killed mid-write (harmless: the
            result they were writing never counted as finished).
    """

    path: Path
    sqlite: list[str] = field(default_factory=list)
    n_rows: int = 0
    n_ok: int = 0
    bad_rows: list[tuple[str, str]] = field(default_factory=list)
    spool_pending: int = 0
    spool_unreadable: list[str] = field(default_factory=list)
    spool_rejected: int = 0
    spool_partial: int = 0

    @property
    def ok(self) -> bool:
        """True when SQLite, every row and every pending spool file are sound."""
        return (self.sqlite == ["ok"] and not self.bad_rows and not self.spool_unreadable
                and self.spool_rejected == 0)

    @property
    def failures(self) -> int:
        """Number of problems found (0 for a sound store)."""
        return ((self.sqlite != ["ok"]) + len(self.bad_rows) + len(self.spool_unreadable)
                + self.spool_rejected)

    def summary(self) -> str:
        """One line: sound or not, with the counts."""
        state = "sound" if self.ok else "DAMAGED"
        sqlite = "ok" if self.sqlite == ["ok"] else "; ".join(self.sqlite[:3])
        return (
            f"{self.path}: {state}: SQLite integrity {sqlite}; {self.n_rows} evaluations "
            f"({self.n_ok} ok), {len(self.bad_rows)} failing their checksum; spool: "
            f"{self.spool_pending} pending, {len(self.spool_unreadable)} unreadable, "
            f"{self.spool_rejected} rejected, {self.spool_partial} partial"
        )


def check_store(path: str | Path) -> IntegrityReport:
    """Check a store without writing to it.

    Args:
        path: the store's SQLite file (its spool folder is ``<path>.spool``).

    Returns:
        The :class:`IntegrityReport`; a file SQLite cannot read as a database gives
        ``sqlite = ["not a database: ..."]``.

    Raises:
        FileNotFoundError: if ``path`` does not exist.
    """
    path = Path(path).expanduser().resolve()
    if not path.is_file():
        raise FileNotFoundError(f"no evaluation store at {path}")
    report = IntegrityReport(path)
    try:
        con = sqlite3.connect(path, timeout=120.0, isolation_level=None)
        try:
            report.sqlite = [str(r[0]) for r in con.execute("PRAGMA integrity_check")]
            for row in con.execute(f"SELECT {COLUMNS} FROM evaluations"):
                report.n_rows += 1
                record = row_record(row)
                if record is None:
                    report.bad_rows.append((str(row[0]), str(row[1])))
                elif record.ok:
                    report.n_ok += 1
        finally:
            con.close()
    except sqlite3.DatabaseError as exc:
        report.sqlite = [f"not a readable evaluation store: {exc}"]
    _check_spool(path.with_name(path.name + ".spool"), report)
    return report


def _check_spool(folder: Path, report: IntegrityReport) -> None:
    if not folder.is_dir():
        return
    for item in sorted(folder.glob("[!.]*.npz")):
        try:
            spool.read(item)
        except ValueError:
            if item.exists():  # else ingested meanwhile by a running process
                report.spool_unreadable.append(item.name)
            continue
        report.spool_pending += 1
    rejected = folder / "rejected"
    report.spool_rejected = len(list(rejected.glob("*.npz"))) if rejected.is_dir() else 0
    report.spool_partial = len(list(folder.glob(".tmp-*")))


def main(argv: list[str] | None = None) -> int:
    """``python -m torchshm.storage.integrity STORE ...``: one line per store; status 1 if
    any is damaged."""
    paths = sys.argv[1:] if argv is None else argv
    status = 0
    for name in paths:
        try:
            report: Any = check_store(name)
        except FileNotFoundError as exc:
            print(f"{name}: {exc}", file=sys.stderr)
            status = 1
            continue
        print(report.summary())
        status = max(status, 0 if report.ok else 1)
    return status


if __name__ == "__main__":
    raise SystemExit(main())

"""The table of an evaluation store: its SQLite schema and how a row becomes a :class:`Record`.

Shared by the store (:mod:`.store`), which writes and reads rows, and the integrity check
(:mod:`.integrity`), which reads them without changing the file.
"""

from __future__ import annotations

import numpy as np

from torchshm.storage.record import Record, record_checksum

#: version of the table layout, stored in the ``meta`` table
SCHEMA_VERSION = "1"
#: the columns of a row, in the order of :func:`row_record`
COLUMNS = (
    "model, theta_key, status, outputs, n_loads, n_points, checksum, error, wall_time_s, "
    "finished_at, host, pid, traceback"
)
SCHEMA = f"""
CREATE TABLE IF NOT EXISTS evaluations (
    model TEXT NOT NULL, theta_key TEXT NOT NULL,
    status TEXT NOT NULL CHECK (status IN ('ok', 'failed')),
    outputs BLOB, n_loads INTEGER, n_points INTEGER, checksum TEXT NOT NULL,
    error TEXT, wall_time_s REAL, finished_at TEXT, host TEXT, pid INTEGER, traceback TEXT,
    PRIMARY KEY (model, theta_key));
CREATE TABLE IF NOT EXISTS meta (name TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS claims (
    model TEXT NOT NULL, theta_key TEXT NOT NULL, host TEXT NOT NULL, pid INTEGER NOT NULL,
    started TEXT NOT NULL, claimed_at REAL NOT NULL, PRIMARY KEY (model, theta_key));
INSERT OR IGNORE INTO meta VALUES ('schema_version', '{SCHEMA_VERSION}');
"""
# An ok evaluation is never overwritten; a failed one is replaced by any newer result.
UPSERT = f"""
INSERT INTO evaluations ({COLUMNS}) VALUES ({", ".join("?" * 13)})
ON CONFLICT (model, theta_key) DO UPDATE SET
    status = excluded.status, outputs = excluded.outputs, n_loads = excluded.n_loads,
    n_points = excluded.n_points, checksum = excluded.checksum, error = excluded.error,
    wall_time_s = excluded.wall_time_s, finished_at = excluded.finished_at,
    host = excluded.host, pid = excluded.pid, traceback = excluded.traceback
WHERE evaluations.status <> 'ok'
"""


def row_record(row: tuple) -> Record | None:
    """Record of a database row, or None when its checksum shows it is damaged."""
    model, key, status, blob, n_loads, n_points, checksum, error = row[:8]
    outputs = None
    if blob is not None:
        if n_loads is None or n_points is None or len(blob) != 8 * n_loads * n_points:
            return None
        outputs = np.frombuffer(blob, dtype="<f8").reshape(n_loads, n_points).astype(np.float64)
    if (status == "ok") == (outputs is None):
        return None
    if record_checksum(model, key, status, outputs, error) != checksum:
        return None
    return Record(
        model=model, key=key, status=status, outputs=outputs, error=error,
        wall_time=float("nan") if row[8] is None else float(row[8]),  # SQLite stores NaN as NULL
        finished_at=row[9], host=row[10], pid=row[11], traceback=row[12],
    )

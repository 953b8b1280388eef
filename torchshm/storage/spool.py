"""Spool folder: how workers on other machines hand finished evaluations to the store.

A worker writes each record to a temporary file, flushes it to disk and renames it to its
final name. A rename within one folder is atomic on local file systems and on NFS, so a file
under a final name is always complete; a worker killed mid-write leaves only a ``.tmp-`` file,
which is ignored. The process that owns the SQLite store ingests the files and deletes them.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import uuid
from collections.abc import Callable
from pathlib import Path

import numpy as np

from torchshm.storage.record import Record

logger = logging.getLogger(__name__)


def deposit(folder: Path, record: Record) -> Path:
    """Write one record durably as ``<folder>/<hash>-<uuid>.npz``; returns its path."""
    folder.mkdir(parents=True, exist_ok=True)
    name = f"{_digest(record.model, record.key)}-{uuid.uuid4().hex[:12]}.npz"
    temporary, final = folder / f".tmp-{name}", folder / name
    meta = dict(record.metadata(), checksum=record.checksum)
    outputs = np.empty((0, 0)) if record.outputs is None else record.outputs
    try:
        with open(temporary, "wb") as handle:
            np.savez(handle, outputs=outputs, meta=np.array(json.dumps(meta)))
            handle.flush()
            os.fsync(handle.fileno())
    except OSError:  # disk full or read-only: leave no partial file behind
        temporary.unlink(missing_ok=True)
        raise
    os.replace(temporary, final)
    _fsync_folder(folder)
    return final


def find(folder: Path, model: str, key: str) -> Record | None:
    """A complete, readable record of ``model`` at ``key`` deposited in ``folder``, or None.

    Successful records are preferred to failed ones; unreadable files are skipped (the next
    :func:`ingest` rejects them).
    """
    found = None
    for path in sorted(folder.glob(f"{_digest(model, key)}-*.npz")):
        try:
            record = read(path)
        except (ValueError, OSError):
            continue
        if record.model == model and record.key == key and (found is None or record.ok):
            found = record
    return found


def read(path: Path) -> Record:
    """Record of one spool file.

    Raises:
        ValueError: if the file cannot be read or its checksum does not match.
    """
    try:
        with np.load(path, allow_pickle=False) as data:
            meta = json.loads(str(data["meta"]))
            outputs = np.array(data["outputs"], dtype=np.float64)
        checksum = meta.pop("checksum", None)
        record = Record(outputs=outputs if meta["status"] == "ok" else None, **meta)
    except Exception as exc:  # any unreadable file is rejected, whatever numpy raises
        raise ValueError(f"unreadable spool file {path.name}: {exc}") from None
    if record.checksum != checksum:
        raise ValueError(f"spool file {path.name} fails its checksum")
    return record


def ingest(folder: Path, put: Callable[[Record], bool]) -> int:
    """Pass every complete spool file to ``put`` and delete it afterwards.

    Unreadable files are moved to ``<folder>/rejected/`` with a warning.

    Returns:
        The number of files ingested.
    """
    if not folder.is_dir():
        return 0
    count = 0
    for path in sorted(folder.glob("[!.]*.npz")):
        try:
            record = read(path)
        except ValueError as exc:
            if path.exists():  # else another process ingested it meanwhile
                logger.warning("%s; moved to %s", exc, folder / "rejected")
                (folder / "rejected").mkdir(exist_ok=True)
                os.replace(path, folder / "rejected" / path.name)
            continue
        put(record)
        path.unlink(missing_ok=True)
        count += 1
    return count


def _digest(model: str, key: str) -> str:
    """File-name prefix shared by every spool file of one model and θp."""
    return hashlib.sha256(f"{model}\0{key}".encode()).hexdigest()[:16]


def _fsync_folder(folder: Path) -> None:
    """Make a rename durable (not possible on every platform, hence best effort)."""
    try:
        descriptor = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(descriptor)
    except OSError:
        pass
    finally:
        os.close(descriptor)

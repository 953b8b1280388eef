"""The run folders of an external program: names a person can find, an index, what is kept.

Each run of :class:`~torchshm.forward.ExternalModel` gets a folder ``run-0007-<hash>`` under
the model's ``workdir`` (numbered in the order the runs start, ``<hash>`` the first 8 hex
digits of the SHA-256 of θp), and one row in ``index.csv`` beside the folders::

    run,status,kept,bytes,seconds,folder,theta_p,error
    7,ok,no,81920,0.61,run-0007-3fa2c1d0,E=34.0 log10_k_B=6.5,
    8,failed,yes,4096,0.02,run-0008-0b77e415,E=-1.0 log10_k_B=6.5,program exited with status 2 ...

``status`` is ``running`` until the run ends, then ``ok`` or ``failed``; ``kept`` says whether
the folder is still on disk; ``bytes`` is the folder's size when the run ended. The keep policy
decides what stays: ``"failed"`` (default: a successful run's folder is removed once its
strains are read, a failed one is kept to be looked at), ``"all"`` or ``"none"``. Several
processes (joblib workers, cluster jobs on a shared file system) may share one ``workdir``:
the numbering and the index are updated under an exclusive lock (``fcntl.flock``).
"""

from __future__ import annotations

import csv
import fcntl
import hashlib
import io
import os
import shutil
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

import numpy as np

INDEX_FILE = "index.csv"
KEEP_POLICIES = ("failed", "all", "none")
COLUMNS = ("run", "status", "kept", "bytes", "seconds", "folder", "theta_p", "error")


def check_keep(keep: str) -> str:
    """``keep`` if it is a known policy (``ValueError`` naming the choices otherwise)."""
    if keep not in KEEP_POLICIES:
        raise ValueError(f"keep must be one of {', '.join(KEEP_POLICIES)}, got {keep!r}")
    return keep


def folder_bytes(path: Path) -> int:
    """Bytes of the regular files under ``path`` (0 if it does not exist)."""
    if not path.exists():
        return 0
    return sum(p.lstat().st_size for p in path.rglob("*") if p.is_file() and not p.is_symlink())


class RunFolders:
    """Numbered run folders under ``root``, their index and the keep policy.

    Args:
        root: the model's work folder (created on the first run).
        keep: ``"failed"``, ``"all"`` or ``"none"``: which run folders stay on disk.
    """

    def __init__(self, root: Path, keep: str = "failed") -> None:
        self.root, self.keep = Path(root), check_keep(keep)

    @property
    def index(self) -> Path:
        """The index file, ``<root>/index.csv``."""
        return self.root / INDEX_FILE

    def new(self, theta: np.ndarray, names: Sequence[str]) -> Path:
        """Create the next run's folder for θp `P` and add its row (status ``running``)."""
        tag = hashlib.sha256(np.ascontiguousarray(theta, dtype=np.float64).tobytes()).hexdigest()[:8]
        label = " ".join(f"{name}={float(value)!r}" for name, value in zip(names, theta))
        with self._locked() as rows:
            numbers = [int(row["run"]) for row in rows]
            numbers += [int(p.name.split("-")[1]) for p in self.root.glob("run-*-*") if p.name.split("-")[1].isdigit()]
            number = max(numbers, default=0) + 1  # also past folders left by a deleted index
            folder = self.root / f"run-{number:04d}-{tag}"
            folder.mkdir()
            rows.append({"run": str(number), "status": "running", "kept": "yes", "bytes": "",
                         "seconds": "", "folder": folder.name, "theta_p": label, "error": ""})
        return folder

    def finish(self, folder: Path, ok: bool, seconds: float, error: str = "") -> None:
        """Record how the run in ``folder`` ended (after ``seconds``) and remove its folder if
        the policy says so."""
        size = folder_bytes(folder)
        keep = self.keep == "all" or (self.keep == "failed" and not ok)
        if not keep:
            shutil.rmtree(folder, ignore_errors=True)
        with self._locked() as rows:
            for row in rows:
                if row["folder"] == folder.name:
                    row.update(status="ok" if ok else "failed", kept="yes" if keep else "no",
                               bytes=str(size), seconds=f"{seconds:.3g}", error=error.replace("\n", " "))

    def rows(self) -> list[dict[str, str]]:
        """The index's rows, one per run started in ``root`` (empty before the first run)."""
        if not self.index.is_file():
            return []
        with open(self.index, newline="") as handle:
            return list(csv.DictReader(handle))

    def disk_used(self) -> int:
        """Bytes under ``root`` now (kept run folders and the index)."""
        return folder_bytes(self.root)

    def summary(self) -> str:
        """One line: runs by status, folders kept, disk used, e.g. ``240 runs (238 ok, 2
        failed), 2 folders kept, 0.1 MB in /home/me/runs/fe``."""
        rows = self.rows()
        count = {s: sum(r["status"] == s for r in rows) for s in ("ok", "failed", "running")}
        kept = sum(r["kept"] == "yes" for r in rows)
        states = ", ".join(f"{n} {s}" for s, n in count.items() if n)
        return (f"{len(rows)} runs ({states or 'none'}), {kept} folders kept (keep={self.keep!r}), "
                f"{self.disk_used() / 1e6:.1f} MB in {self.root}")

    @contextmanager
    def _locked(self) -> Iterator[list[dict[str, str]]]:
        """The index's rows under an exclusive lock; written back (atomically) on exit."""
        self.root.mkdir(parents=True, exist_ok=True)
        with open(self.root / f".{INDEX_FILE}.lock", "a") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            try:
                rows = self.rows()
                yield rows
                text = io.StringIO()
                writer = csv.DictWriter(text, fieldnames=COLUMNS, lineterminator="\n")
                writer.writeheader()
                writer.writerows(rows)
                temporary = self.root / f".{INDEX_FILE}.{os.getpid()}.tmp"
                temporary.write_text(text.getvalue())
                os.replace(temporary, self.index)
            finally:
                fcntl.flock(lock, fcntl.LOCK_UN)


__all__ = ["INDEX_FILE", "KEEP_POLICIES", "RunFolders", "check_keep", "folder_bytes"]

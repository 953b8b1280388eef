"""A forward model that runs an external finite element program, once per θp.

Each run gets a fresh work folder ``<workdir>/run-0007-<hash>/`` holding ``params.json``
(input), ``run.log`` (the program's stdout and stderr) and the strain file the program writes
(output); the file contract is in :mod:`torchshm.forward.files` and
``docs/external_models.md``. ``<workdir>/index.csv`` maps each run to its θp, status and
folder, and by default only failed runs keep their folders (:mod:`torchshm.forward.runs`); the run itself is
:func:`torchshm.forward.program.run_program`. A run that exits with a
non-zero status, exceeds its timeout or writes no valid strains raises
:class:`ExternalModelError`, which the evaluation store records as a failed evaluation.
"""

from __future__ import annotations

import hashlib
import json
import os
import signal
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import torch
from torch import Tensor

from torchshm.forward.axes import load_axis
from torchshm.forward.files import LOG_FILE, PARAMS_FILE, read_strains, write_params
from torchshm.forward.protocol import as_tensor
from torchshm.forward.program import ExternalModelError, log_tail, run_program
from torchshm.forward.runs import RunFolders


#: default largest file a run may write [bytes] (strains of 100 load cases x 100,000 sensors
#: as CSV take about 0.3 GiB)
DEFAULT_MAX_OUTPUT_BYTES = 1 << 30


class ExternalModel:
    """Wrap an external FE program as a forward model (one program run per θp).

    Args:
        command: the program, as a list of arguments (run directly) or a string (run by the
            shell). It runs with the work folder as current directory, so give scripts and
            input files by absolute path. ``TORCHSHM_PARAMS``, ``TORCHSHM_OUTPUT`` and
            ``TORCHSHM_WORKDIR`` hold the absolute paths of the run's files and folder.
        x: sensor positions `n` [m]: values, a range ``{"start", "stop", "num"}`` or a
            ``.csv``/``.npy`` file (:func:`torchshm.forward.axes.load_axis`).
        loads: load cases `L` (e.g. front-axle positions [m]), given as ``x`` is.
        timeout: seconds after which a run is killed (its whole process group); None: never.
        workdir: folder under which each run gets its own sub-folder ``run-0007-<hash>`` and
            ``index.csv`` its row; None: a ``torchshm-runs`` folder in the system's temporary
            folder.
        output: name of the strain file the program writes, ``*.npz`` or ``*.csv``.
        names: parameter names written to ``params.json``; None: ``theta_0, theta_1, ...``.
        identity: key of this model in an evaluation store; None: a hash of the command,
            output name, parameter names, x and loads.
        keep: which run folders stay on disk: ``"failed"`` (a successful run's folder is
            removed once its strains are read), ``"all"`` or ``"none"``.
        keep_workdirs: older spelling of ``keep``: True is ``"all"``, False ``"failed"``.
        kill_grace: seconds between SIGTERM and SIGKILL when a run times out.
        max_output_bytes: largest file a run may write (its strain file and log included),
            enforced on the program by the operating system (``RLIMIT_FSIZE``: a write past it
            stops the program) and checked before the strain file is read; None: no limit.

    Security: parameters reach the program only through ``params.json`` and the environment,
    never through a command line or a shell (a string ``command`` is the user's own shell
    line, run as written); each run's current directory is its own work folder, and a strain
    file that is a link or lies outside that folder is refused. Strain files are read without
    pickle (``np.load(allow_pickle=False)``, CSV as text).

    Raises:
        ValueError: on an empty command, non-finite or non-1-D ``x``/``loads`` (or an
            unreadable file of them), a non-positive timeout or output limit, an output name
            that is not ``.npz``/``.csv``, or an unknown ``keep``.
    """

    def __init__(
        self,
        command: str | Sequence[str],
        x: object,
        loads: object,
        timeout: float | None = None,
        workdir: str | Path | None = None,
        output: str = "strains.npz",
        *,
        names: Sequence[str] | None = None,
        identity: str | None = None,
        keep: str = "failed",
        keep_workdirs: bool | None = None,
        kill_grace: float = 5.0,
        max_output_bytes: int | None = DEFAULT_MAX_OUTPUT_BYTES,
    ) -> None:
        self.command = _check_command(command)
        self.x, self.loads = (torch.from_numpy(load_axis(v, k)) for k, v in (("x", x), ("loads", loads)))
        if timeout is not None and not (isinstance(timeout, (int, float)) and timeout > 0):
            raise ValueError(f"timeout must be positive seconds or None, got {timeout!r}")
        if Path(output).suffix not in (".npz", ".csv") or Path(output).name != output:
            raise ValueError(f"output must be a file name ending in .npz or .csv, got {output!r}")
        self.timeout, self.output = timeout, output
        base = Path(tempfile.gettempdir()) / "torchshm-runs" if workdir is None else Path(workdir)
        self.workdir = base.expanduser().resolve()
        self.names = None if names is None else [str(name) for name in names]
        if keep_workdirs is not None:
            keep = "all" if keep_workdirs else "failed"
        self.folders = RunFolders(self.workdir, keep)
        self.kill_grace = float(kill_grace)
        if max_output_bytes is not None and (
            isinstance(max_output_bytes, bool) or not isinstance(max_output_bytes, int)
            or max_output_bytes <= 0
        ):
            raise ValueError(f"max_output_bytes must be a positive integer or None, got {max_output_bytes!r}")
        self.max_output_bytes = max_output_bytes
        self.identity = identity if identity is not None else self._default_identity()

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.command!r}, n={len(self.x)}, L={len(self.loads)})"

    @property
    def keep(self) -> str:
        """Which run folders stay on disk: ``"failed"``, ``"all"`` or ``"none"``."""
        return self.folders.keep

    @property
    def keep_workdirs(self) -> bool:
        """Whether successful runs keep their folders (``keep == "all"``)."""
        return self.folders.keep == "all"

    @property
    def disk_used(self) -> int:
        """Bytes under ``workdir`` now: the kept run folders and ``index.csv``."""
        return self.folders.disk_used()

    def runs_summary(self) -> str:
        """One line from ``index.csv``: runs by status, folders kept and disk used."""
        return self.folders.summary()

    def __call__(self, theta_p: object) -> Tensor:
        """Strains [µε] `... x L x n` for parameters `... x P`, one program run per row."""
        theta = as_tensor(theta_p).detach()
        if theta.ndim == 0:
            raise ValueError("theta_p must have at least one dimension (..., P)")
        rows = theta.reshape(-1, theta.shape[-1]).cpu().numpy()
        strains = [self.run(row) for row in rows]
        out = np.stack(strains) if strains else np.empty((0, len(self.loads), len(self.x)))
        return torch.from_numpy(out).reshape(*theta.shape[:-1], len(self.loads), len(self.x))

    def run(self, theta: np.ndarray) -> np.ndarray:
        """Run the program once for parameters `P`; returns strains [µε] `L x n`.

        Raises:
            ValueError: if ``theta`` is not finite or has the wrong length.
            ExternalModelError: if the program fails, times out or writes no valid strains.
        """
        theta = np.asarray(theta, dtype=np.float64).reshape(-1)
        names = self.names or [f"theta_{i}" for i in range(len(theta))]
        if len(names) != len(theta) or not np.isfinite(theta).all():
            raise ValueError(f"theta_p {theta.tolist()} must be {len(names)} finite values")
        folder, start = self.folders.new(theta, names), time.perf_counter()
        try:
            self._prepare(folder, theta, names)
            self._execute(folder)
            try:
                strain = self._read(folder)
            except ValueError as exc:
                raise ExternalModelError(f"{exc} (work folder {folder})") from None
        except BaseException as exc:  # failed or interrupted: the folder is kept unless keep="none"
            self.folders.finish(folder, False, time.perf_counter() - start, str(exc) or type(exc).__name__)
            raise
        self.folders.finish(folder, True, time.perf_counter() - start)
        return strain

    def _prepare(self, folder: Path, theta: np.ndarray, names: list[str]) -> None:
        """Write the run's input files into ``folder`` (here ``params.json``)."""
        write_params(folder / PARAMS_FILE, theta, names, self.x.numpy(), self.loads.numpy())

    def _read(self, folder: Path) -> np.ndarray:
        """Strains [µε] `L x n` the run wrote into ``folder`` (``ValueError`` if unusable)."""
        return read_strains(self._output_file(folder), self.x.numpy(), self.loads.numpy())

    def _hit_size_limit(self, folder: Path) -> bool:
        """Whether a file in the run's folder reached ``max_output_bytes`` (the system refuses
        writes past it: the program gets SIGXFSZ, or an error where it ignores the signal)."""
        limit = self.max_output_bytes
        return limit is not None and any(
            path.is_file() and path.stat().st_size >= limit for path in folder.rglob("*")
        )

    def _output_file(self, folder: Path) -> Path:
        """The run's strain file, checked to be a regular file inside ``folder`` within the
        size limit (``ValueError`` otherwise)."""
        path = folder / self.output
        if path.is_symlink() or (path.exists() and path.resolve().parent != folder.resolve()):
            raise ValueError(f"strain file {path} is a link; a run may only write inside its work folder")
        if path.is_file() and self.max_output_bytes is not None:
            size = path.stat().st_size
            if size > self.max_output_bytes:
                raise ValueError(
                    f"strain file {path} has {size} bytes, over max_output_bytes={self.max_output_bytes}"
                )
        return path

    def _execute(self, folder: Path) -> None:
        """Run the command in ``folder``, output to run.log, and check how it ended."""
        env = dict(os.environ, TORCHSHM_PARAMS=str(folder / PARAMS_FILE),
                   TORCHSHM_OUTPUT=str(folder / self.output), TORCHSHM_WORKDIR=str(folder))
        status = run_program(self.command, folder, env, self.timeout, self.kill_grace, self.max_output_bytes)
        if status != 0 and (status == -signal.SIGXFSZ or self._hit_size_limit(folder)):
            raise ExternalModelError(
                f"program stopped for writing a file over max_output_bytes="
                f"{self.max_output_bytes} (work folder {folder})"
            )
        if status != 0:
            raise ExternalModelError(
                f"program exited with status {status} (work folder {folder}); "
                f"last output: {log_tail(folder / LOG_FILE)!r}"
            )

    def _default_identity(self) -> str:
        config = json.dumps({"command": self.command, "output": self.output, "names": self.names})
        digest = hashlib.sha256(config.encode())
        digest.update(self.x.numpy().tobytes())
        digest.update(self.loads.numpy().tobytes())
        return f"ExternalModel-{digest.hexdigest()[:16]}"


def _check_command(command: str | Sequence[str]) -> str | list[str]:
    if isinstance(command, (str, os.PathLike)):
        text = os.fspath(command)
        if not text.strip():
            raise ValueError("command is empty")
        return text
    args = [os.fspath(arg) for arg in command]
    if not args or not all(isinstance(arg, str) and arg for arg in args):
        raise ValueError(f"command must be a non-empty list of non-empty strings, got {command!r}")
    return args


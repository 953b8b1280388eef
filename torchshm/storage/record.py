"""One forward-model evaluation: running it, checking its output, and its stored form.

A :class:`Record` is what the store keeps for every finished model run, whether it succeeded
or failed. :func:`run_model` makes one by calling the model with a single parameter vector;
it never raises for a failing model, it records the failure instead, so that one bad run
does not end a study of hundreds of 10-minute runs.
"""

from __future__ import annotations

import hashlib
import logging
import os
import socket
import time
import traceback
from dataclasses import dataclass
from datetime import datetime, timezone
from typing import TYPE_CHECKING, Any

import numpy as np
import torch
from torch import Tensor

if TYPE_CHECKING:
    from torchshm.forward.protocol import ForwardModel

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class Record:
    """A finished evaluation of one forward model at one parameter vector.

    Attributes:
        model: the model's identity (see :func:`torchshm.forward.model_identity`).
        key: canonical key of the parameter vector (see :func:`theta_key`).
        status: ``"ok"`` or ``"failed"``.
        outputs: strains [µε] `L x n` (float64) when ``status == "ok"``, else None.
        error: one-paragraph error text when ``status == "failed"``, else None.
        wall_time: seconds the model call took.
        finished_at: ISO 8601 UTC time at which the call returned.
        host: name of the machine that ran it.
        pid: process id that ran it.
        traceback: the Python traceback of a failure, for debugging.
    """

    model: str
    key: str
    status: str
    outputs: np.ndarray | None
    error: str | None
    wall_time: float
    finished_at: str
    host: str
    pid: int
    traceback: str | None = None

    @property
    def ok(self) -> bool:
        """Whether the evaluation succeeded."""
        return self.status == "ok"

    @property
    def checksum(self) -> str:
        """SHA-256 over the key, status, shape, output bytes and error text."""
        return record_checksum(self.model, self.key, self.status, self.outputs, self.error)

    def metadata(self) -> dict[str, Any]:
        """Every field except ``outputs``, as JSON-ready values."""
        return {
            "model": self.model, "key": self.key, "status": self.status, "error": self.error,
            "wall_time": self.wall_time, "finished_at": self.finished_at, "host": self.host,
            "pid": self.pid, "traceback": self.traceback,
        }


def record_checksum(
    model: str, key: str, status: str, outputs: np.ndarray | None, error: str | None
) -> str:
    """Checksum of a record's content; a stored value whose checksum differs is not valid."""
    digest = hashlib.sha256("\0".join((model, key, status, str(error))).encode())
    if outputs is not None:
        digest.update(repr(tuple(outputs.shape)).encode())
        digest.update(np.ascontiguousarray(outputs, dtype="<f8").tobytes())
    return digest.hexdigest()


def check_outputs(raw: object, shape: tuple[int, int]) -> np.ndarray:
    """Validate a model's output for one θp and return it as a float64 `L x n` array.

    Args:
        raw: what the model returned: a tensor or array `L x n` (or `1 x L x n`).
        shape: the expected `(L_model, n_model)`.

    Raises:
        ValueError: on a wrong shape or dtype (complex, bool, text) or on NaN or inf values
            (the message counts them).
    """
    check_dtype(raw)
    if isinstance(raw, Tensor):
        raw = raw.detach().cpu().numpy()
    outputs = np.asarray(raw, dtype=np.float64)
    if outputs.ndim == len(shape) + 1 and outputs.shape[0] == 1:
        outputs = outputs[0]
    if outputs.shape != tuple(shape):
        raise ValueError(f"model output has shape {outputs.shape}, expected (L, n) = {shape}")
    n_nan = int(np.isnan(outputs).sum())
    n_inf = int(np.isinf(outputs).sum())
    if n_nan or n_inf:
        raise ValueError(
            f"model output has {n_nan} NaN and {n_inf} inf values (of {outputs.size})"
        )
    return np.ascontiguousarray(outputs)


def check_dtype(raw: object) -> None:
    """Refuse a model output whose dtype is not real numbers: converting a complex output to
    float64 would silently drop its imaginary part, a bool or text one is no strain.

    Raises:
        ValueError: naming the dtype.
    """
    dtype = raw.dtype if isinstance(raw, (Tensor, np.ndarray)) else None
    if isinstance(raw, Tensor):
        bad = raw.is_complex() or dtype == torch.bool
    else:
        bad = dtype is not None and dtype.kind not in "fiu"
    if bad:
        raise ValueError(f"model output has dtype {dtype}; expected real numbers (float64)")


def error_text(exc: BaseException) -> str:
    """``"TypeName: message"`` of an exception."""
    message = str(exc).strip()
    return f"{type(exc).__name__}: {message}" if message else type(exc).__name__


def now_utc() -> str:
    """Current time as ISO 8601 UTC text."""
    return datetime.now(timezone.utc).isoformat(timespec="milliseconds")


def run_model(
    model: ForwardModel, identity: str, key: str, theta: np.ndarray, shape: tuple[int, int]
) -> Record:
    """Call a forward model once and record the outcome; never raises for a model failure.

    Args:
        model: the forward model; it receives a float64 tensor `P`.
        identity: the model's identity.
        key: canonical key of ``theta``.
        theta: canonical parameter vector `P`.
        shape: expected output shape `(L_model, n_model)`.

    Returns:
        An ``"ok"`` record with the strains [µε], or a ``"failed"`` one with the error text
        when the model raised or returned a wrong shape, NaN or inf. ``KeyboardInterrupt``
        and ``SystemExit`` are not caught.
    """
    start = time.perf_counter()
    outputs: np.ndarray | None = None
    error = trace = None
    try:
        with torch.no_grad():
            raw = model(torch.as_tensor(theta, dtype=torch.float64))
        outputs = check_outputs(raw, shape)
    except Exception as exc:  # a failing model run is data, not a crash
        error, trace = error_text(exc), traceback.format_exc()
    wall = time.perf_counter() - start
    status = "ok" if error is None else "failed"
    logger.info("evaluation %s of %s at θp=[%s] in %.3g s", status, identity, key, wall)
    return Record(
        model=identity, key=key, status=status, outputs=outputs, error=error, wall_time=wall,
        finished_at=now_utc(), host=socket.gethostname(), pid=os.getpid(), traceback=trace,
    )

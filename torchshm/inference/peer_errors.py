"""Numerical failures inside a peer library (PyVBMC and its GP, emcee), told in one line.

A failure raised from inside PyVBMC, gpyreg, emcee, numpy or scipy while a method runs (e.g.
``numpy.linalg.LinAlgError: Singular matrix`` from PyVBMC's Gaussian process when the log
joint is extremely peaked) is turned into a :class:`PeerNumericalError` whose message names the
library, the error, the likely cause and what to change. Errors raised by torchshm's own code
(a model error, a refused input) pass through unchanged.
"""

from __future__ import annotations

import traceback

import numpy as np

#: the exception types a numerical failure of a peer library raises
NUMERICAL = (np.linalg.LinAlgError, FloatingPointError, ZeroDivisionError, ValueError)
#: packages whose failures are turned into PeerNumericalError (numpy and scipy frames are
#: looked through: the caller decides)
PEERS = ("pyvbmc", "gpyreg", "emcee", "cma")


class PeerNumericalError(RuntimeError):
    """A numerical failure inside a peer library, with its cause and what to change (one line)."""


def peer_of(exc: BaseException) -> str | None:
    """The peer package that raised ``exc``, or None when torchshm's own code did.

    Frames are read from the innermost outwards: the first one in torchshm or in a peer
    package (:data:`PEERS`) decides; others (numpy, scipy, a user's function) are looked
    through."""
    frames = traceback.extract_tb(exc.__traceback__)
    for frame in reversed(frames):
        path = frame.filename.replace("\\", "/")
        if "/torchshm/" in path:
            return None
        for peer in PEERS:
            if f"/{peer}/" in path:
                return peer
    return None


def where(exc: BaseException) -> str:
    """``"module.py:line in function"`` of the innermost frame of ``exc``."""
    frames = traceback.extract_tb(exc.__traceback__)
    if not frames:
        return "unknown place"
    last = frames[-1]
    return f"{last.filename.rsplit('/', 2)[-2]}/{last.filename.rsplit('/', 1)[-1]}:{last.lineno} in {last.name}"


def first_line(exc: BaseException) -> str:
    """``"TypeName: first line of the message"``."""
    lines = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {lines[0] if lines else ''}".rstrip(": ")


def log_joint_range(y: list[float]) -> str:
    """``"a log-joint range of 1.2e+06 nats over 40 points"`` of the finite values ``y``."""
    values = np.asarray(y, dtype=np.float64)
    values = values[np.isfinite(values)]
    if values.size < 2:
        return f"{values.size} finite log-joint values"
    return f"a log-joint range of {np.ptp(values):.3g} nats over {values.size} points"


__all__ = ["NUMERICAL", "PEERS", "PeerNumericalError", "first_line", "log_joint_range", "peer_of",
           "where"]

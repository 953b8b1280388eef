"""Small look-ups shared by the predictive functions: load cases, positions, parameters, seeds."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Iterable

import numpy as np
import torch
from torch import Tensor

from torchshm.kernels import get_kernel

from torchshm.data.measurements import POSITION_TOL


def problem_of(post: Any, problem: Any | None) -> Any:
    """The problem to use: ``problem`` when given, else ``post.problem``.

    Raises:
        ValueError: when neither is available (e.g. a posterior loaded from file).
    """
    problem = problem if problem is not None else getattr(post, "problem", None)
    if problem is None:
        raise ValueError(
            "the posterior carries no Problem (was it loaded from a file?); pass problem=..."
        )
    return problem


def _match(values: np.ndarray, wanted: np.ndarray, what: str) -> Tensor:
    """Indices of ``wanted`` in ``values`` within POSITION_TOL; ValueError naming a missing one."""
    index = []
    for value in wanted:
        hits = np.flatnonzero(np.abs(values - value) <= POSITION_TOL)
        if hits.size == 0:
            known = ", ".join(f"{v:g}" for v in values[:20])
            raise ValueError(f"unknown {what} {value:g} (the model has {known}{'...' if values.size > 20 else ''})")
        index.append(int(hits[0]))
    return torch.as_tensor(index, dtype=torch.long)


def _array(values: Any) -> np.ndarray:
    if isinstance(values, Tensor):
        return values.detach().cpu().numpy().astype(np.float64)
    return np.asarray(values, dtype=np.float64)


def load_index(model: Any, loads: Iterable[float] | float) -> Tensor:
    """Indices `L'` of ``loads`` (front-axle positions [m]) in ``model.loads``."""
    wanted = np.atleast_1d(_array(list(loads) if not np.isscalar(loads) else [loads]))
    if wanted.size == 0:
        raise ValueError("no load case to predict")
    return _match(_array(model.loads), wanted, "load case")


def position_index(problem: Any, positions: str) -> tuple[Tensor, Tensor]:
    """Indices into ``model.x`` and the positions `n_x` [m] of the prediction.

    Args:
        problem: the problem (``model.x``, ``measurements.x``).
        positions: ``"measured"`` (the problem's measured positions) or ``"model"`` (all).
    """
    model_x = _array(problem.model.x)
    if positions == "model":
        index = torch.arange(model_x.size)
    elif positions == "measured":
        index = _match(model_x, _array(problem.measurements.x), "position")
    else:
        raise ValueError(f"positions must be 'measured' or 'model', got {positions!r}")
    return index, torch.as_tensor(model_x)[index]


def parameter_columns(problem: Any, names: list[str], theta: np.ndarray) -> tuple[Tensor, Tensor, Tensor | None]:
    """Split posterior draws into the model's `theta_p` and the discrepancy parameters.

    Parameters absent from ``names`` take their fixed value from ``problem.priors``.

    Args:
        problem: the problem (``physical_names``, ``priors``, ``kernel``).
        names: `D` names of the columns of ``theta``.
        theta: `n x D` posterior draws.

    Returns:
        ``theta_p`` (`n x P`, in model order), ``sigma_a`` (`n`) [µε] and ``length`` (`n`) [m],
        ``None`` for a kernel without length.
    """
    priors = problem.priors

    def column(name: str) -> np.ndarray:
        if name in names:
            return theta[:, names.index(name)]
        fixed = priors.get(name) if hasattr(priors, "get") else None
        if isinstance(fixed, (int, float)) and not isinstance(fixed, bool):
            return np.full(theta.shape[0], float(fixed))
        raise ValueError(f"parameter {name!r} is neither inferred nor fixed to a number")

    theta_p = np.column_stack([column(name) for name in problem.physical_names])
    sigma_a = column("sigma_a")
    length = column("length") if get_kernel(problem.kernel).has_length else None
    as_t = lambda a: torch.as_tensor(np.ascontiguousarray(a), dtype=torch.float64)  # noqa: E731
    return as_t(theta_p), as_t(sigma_a), None if length is None else as_t(length)


@dataclass
class RandomStreams:
    """Independent random streams derived from one seed.

    Attributes:
        theta: posterior draws.
        noise: predictive noise draws (the same for the emulated and the exact predictive).
        emulator: draws of the emulator's own uncertainty.
    """

    theta: np.random.Generator
    noise: torch.Generator
    emulator: torch.Generator


def random_streams(seed: int) -> RandomStreams:
    """Three independent streams from ``seed`` (numpy ``SeedSequence.spawn``)."""
    theta_seq, noise_seq, emulator_seq = np.random.SeedSequence(seed).spawn(3)
    noise = torch.Generator().manual_seed(int(noise_seq.generate_state(1, np.uint64)[0] >> 1))
    emulator = torch.Generator().manual_seed(int(emulator_seq.generate_state(1, np.uint64)[0] >> 1))
    return RandomStreams(np.random.default_rng(theta_seq), noise, emulator)

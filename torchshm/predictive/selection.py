"""Small look-ups shared by the predictive functions: load cases, parameters, seeds."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import TYPE_CHECKING, Iterable

import numpy as np
import torch
from torch import Tensor

from torchshm.arrays import as_numpy
from torchshm.data.positions import nearest_index
from torchshm.forward.protocol import ForwardModel

if TYPE_CHECKING:
    from torchshm.inference.protocol import PosteriorLike
    from torchshm.problem import Problem


def problem_of(post: PosteriorLike, problem: Problem | None) -> Problem:
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
    """Indices of ``wanted`` in ``values`` (:func:`~torchshm.data.positions.nearest_index`);
    ValueError naming a missing one."""
    index, found = nearest_index(wanted, values)
    if not found.all():
        value = float(np.asarray(wanted, dtype=np.float64).ravel()[~found][0])
        known = ", ".join(f"{v:g}" for v in values[:20])
        raise ValueError(f"unknown {what} {value:g} (the model has {known}{'...' if values.size > 20 else ''})")
    return torch.as_tensor(index, dtype=torch.long)


def load_index(model: ForwardModel, loads: Iterable[float] | float) -> Tensor:
    """Indices `L'` of ``loads`` (front-axle positions [m]) in ``model.loads``."""
    wanted = np.atleast_1d(as_numpy(list(loads) if not np.isscalar(loads) else [loads]))
    if wanted.size == 0:
        raise ValueError("no load case to predict")
    return _match(as_numpy(model.loads), wanted, "load case")


def parameter_columns(
    problem: Problem, names: list[str], theta: np.ndarray
) -> tuple[Tensor, Tensor, Tensor | None]:
    """Split posterior draws into the model's `theta_p` and the discrepancy parameters.

    Uses the problem's :class:`~torchshm.problem.ParameterSplit` with the posterior's column
    names: parameters absent from ``names`` take their fixed value from the problem.

    Args:
        problem: the problem (its ``split``).
        names: `D` names of the columns of ``theta``.
        theta: `n x D` posterior draws.

    Returns:
        ``theta_p`` (`n x P`, in model order), ``sigma_a`` (`n x G`) [µε] and ``length``
        (`n x G`) [m], ``None`` for a kernel without length; one column per discrepancy group
        (`G` = 1 unless ``discrepancy="per_line"``).

    Raises:
        ValueError: naming a parameter that is neither among ``names`` nor fixed.
    """
    split = dataclasses.replace(problem.split, names=tuple(names))
    rows = np.ascontiguousarray(theta, dtype=np.float64)
    theta_p = split.physical(rows)
    sigma_a, length = split.discrepancy(rows)
    return theta_p.contiguous(), sigma_a.contiguous(), None if length is None else length.contiguous()


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

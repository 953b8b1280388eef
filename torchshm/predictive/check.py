"""How good is the emulator where it matters? The paper's Fig. 7 check.

The emulator of :func:`~torchshm.predictive.posterior_predictive` is trained on the points
inference evaluated, so it should be accurate inside the posterior's high-density region and may
be poor far outside it. :func:`emulator_check` compares it with the forward model on draws at
the boundary of the highest-density region of probability ``level`` (0.99) and on draws outside
it. This check *does* evaluate the model (``2 * n_points`` runs): it is a validation tool.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Iterable

import numpy as np
import torch
from torch import Tensor

from torchshm.predictive.predictive import stored_emulator
from torchshm.predictive.selection import load_index, parameter_columns, problem_of
from torchshm.predictive.view import prediction_view

if TYPE_CHECKING:
    from torchshm.inference.protocol import PosteriorLike
    from torchshm.problem import Problem


@dataclass
class EmulatorCheck:
    """Emulated and exact model responses at two groups of parameter draws.

    Attributes:
        level: probability of the highest-density region.
        boundary_theta, outside_theta: `k x D` draws on its boundary and outside it.
        boundary_exact, boundary_emulated: `k x L' x n_x` model and emulator responses [µε].
        outside_exact, outside_emulated: the same outside the region [µε].
    """

    level: float
    boundary_theta: np.ndarray
    boundary_exact: Tensor
    boundary_emulated: Tensor
    outside_theta: np.ndarray
    outside_exact: Tensor
    outside_emulated: Tensor

    @property
    def boundary_error(self) -> float:
        """Largest absolute emulator error on the boundary [µε]."""
        return float((self.boundary_emulated - self.boundary_exact).abs().max())

    @property
    def outside_error(self) -> float:
        """Largest absolute emulator error outside the region [µε]."""
        return float((self.outside_emulated - self.outside_exact).abs().max())


def emulator_check(
    post: PosteriorLike, loads: Iterable[float] | float, level: float = 0.99, n_points: int = 50,
    n_pool: int = 20_000, seed: int = 0, problem: Problem | None = None,
) -> EmulatorCheck:
    """Compare the emulator with the model on and outside the ``level`` credible region.

    The region is ``{theta: log q(theta) >= t}`` with ``t`` the ``1 - level`` quantile of
    ``log q`` over ``n_pool`` posterior draws. Boundary draws are the ``n_points`` pool draws
    with ``log q`` closest to ``t``; outside draws are pool draws pushed twice as far from the
    posterior mean, kept where ``log q < t`` and inside the hard bounds.

    Args:
        post: a posterior with a density (``log_pdf``; VBMC).
        loads: load cases to check [m]; positions are the problem's measured ones.
        level, n_points, n_pool, seed: see above.
        problem: the problem to use instead of ``post.problem``.

    Returns:
        An :class:`EmulatorCheck`.
    """
    problem = problem_of(post, problem)
    rng = np.random.default_rng(seed)
    pool = np.asarray(post.sample(n_pool, rng), dtype=np.float64)
    log_q = np.asarray(post.log_pdf(pool), dtype=np.float64)
    threshold = float(np.quantile(log_q, 1.0 - level))
    boundary = pool[np.argsort(np.abs(log_q - threshold))[:n_points]]
    pushed = pool.mean(0) + 2.0 * (pool - pool.mean(0))
    hard = np.asarray(problem.hard_bounds, dtype=np.float64)
    inside = np.all((pushed > hard[:, 0]) & (pushed < hard[:, 1]), axis=1)
    pushed = pushed[inside]
    outside = pushed[np.asarray(post.log_pdf(pushed)) < threshold][:n_points]
    emulator = stored_emulator(problem, loads, "measured", seed)
    loads_idx = load_index(problem.model, loads)
    view = prediction_view(problem, "measured")

    def responses(theta: np.ndarray) -> tuple[Tensor, Tensor]:
        theta_p = parameter_columns(problem, list(post.names), theta)[0]
        with torch.no_grad():
            exact = view.apply(torch.as_tensor(problem.model(theta_p), dtype=torch.float64)[:, loads_idx])
            return exact, emulator(theta_p)

    return EmulatorCheck(level, boundary, *responses(boundary), outside, *responses(outside))

"""Independent blocks of Eq. (21): one per (sensor line, set of load cases with the same readings).

A campaign with several sensor lines and dropouts is a sum of independent Gaussians of Eq. (21):
the discrepancy is independent between lines and between load cases, and a dropout (a masked
reading) is simply absent from its own load case's Gaussian. A :class:`Block` is one such
Gaussian: a line's valid readings of one or several load cases. Load cases of a line whose
valid readings are the same positions (no dropout, or the same ones) share one block, so an
unmasked line is one block over all its load cases, exactly as the one-fibre likelihood.

The hook for positions of any dimension: a block's ``x`` is `n_b` arc lengths along its line
(1-D, sorted) or `n_b x d` coordinates (a 2-D/3-D field). Each block is evaluated by
:func:`torchshm.likelihood.log_likelihood` on its own positions: for 1-D positions the
state-space form is taken where ``method="auto"`` chooses it (a masked block is just its own
subset of sorted positions); for `n_b x d` coordinates the kernel is called on the block's
coordinates (``kernel(x_b, sigma_a=..., length=...)`` must accept `n_b x d`, e.g. a kernel of the
Euclidean distance) and the covariance is dense, refused in one line when it would not fit in
memory (:func:`torchshm.likelihood.marginal.choose_method`).

Discrepancy parameters are per *group*: all lines in group 0 (σa and l shared across lines,
the default) or one group per line (``Problem(..., discrepancy="per_line")``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import torch
from torch import Tensor

from torchshm.kernels import Kernel, get_kernel
from torchshm.likelihood.gaussian import log_likelihood
from torchshm.likelihood.statespace import is_markov


@dataclass(frozen=True)
class Block:
    """One independent Gaussian of Eq. (21).

    Attributes:
        loads: `L_b` indices into the load-case axis of ``y`` and ``eta``.
        points: `n_b` indices into the position axis of ``y`` and ``eta``.
        x: `n_b` positions along the line [m] (sorted) or `n_b x d` coordinates [m].
        sigma_e: measurement noise of the line [µε].
        group: column of the discrepancy parameters (σa, l) this block uses.
        line: the line label (``None`` for one unnamed line), for messages.
    """

    loads: Tensor
    points: Tensor
    x: Tensor
    sigma_e: float
    group: int = 0
    line: object = None

    @property
    def size(self) -> int:
        """Readings in the block (`L_b n_b`)."""
        return int(self.loads.numel() * self.points.numel())


def make_blocks(
    x: object,
    mask: np.ndarray,
    slices: Mapping[object, slice],
    sigma_e: Mapping[object, float] | float,
    groups: Mapping[object, int] | None = None,
) -> list[Block]:
    """The blocks of a campaign: per line, one per distinct set of valid readings.

    Args:
        x: `n` positions [m] or `n x d` coordinates [m].
        mask: `L x n` booleans, true where the reading is valid (``Measurements.mask``, or
            :func:`full_mask`).
        slices: line label -> slice of its positions (``Measurements.line_slices()``).
        sigma_e: noise [µε], one number or line label -> number.
        groups: line label -> discrepancy group; ``None`` puts every line in group 0.

    Returns:
        The blocks, line by line in ``slices`` order, load cases in their first appearance order.

    Raises:
        ValueError: if a load case has no valid reading at all.
    """
    xt = torch.as_tensor(np.asarray(x, dtype=np.float64))
    mask = np.asarray(mask, dtype=bool)
    empty = np.flatnonzero(~mask.any(axis=1))
    if empty.size:
        raise ValueError(f"likelihood blocks: load case index {int(empty[0])} has no valid reading")
    out: list[Block] = []
    for label, part in slices.items():
        rows = mask[:, part]
        keys: dict[bytes, list[int]] = {}
        for load, row in enumerate(rows):
            if row.any():
                keys.setdefault(np.packbits(row).tobytes(), []).append(load)
        for loads in keys.values():
            points = np.arange(part.start, part.stop)[rows[loads[0]]]
            noise = sigma_e[label] if isinstance(sigma_e, Mapping) else sigma_e
            out.append(Block(
                torch.as_tensor(loads, dtype=torch.int64), torch.as_tensor(points, dtype=torch.int64),
                xt[points], float(noise), 0 if groups is None else int(groups[label]), label,
            ))
    return out


def full_mask(n_loads: int, n: int) -> np.ndarray:
    """An `L x n` mask with every reading valid."""
    return np.ones((n_loads, n), dtype=bool)


def blocks_log_likelihood(
    y: Tensor,
    eta: Tensor,
    blocks: Sequence[Block],
    kernel: str | Kernel,
    sigma_a: Tensor,
    length: Tensor | None,
    sigma_m: float | Tensor = 0.05,
    method: str = "auto",
    extra_variance: Tensor | None = None,
    sigma_e_scale: Tensor | None = None,
    state_space_from: int | None = None,
) -> Tensor:
    """Sum over ``blocks`` of the log-likelihoods of Eq. (21).

    Args:
        y: `L x n` measured strains [µε] (masked readings may be NaN: no block reads them).
        eta: `B x L x n` model predictions [µε] (differentiable).
        blocks: from :func:`make_blocks`.
        kernel: a kernel name or instance.
        sigma_a: `B x G` discrepancy scales [µε], one column per group (differentiable).
        length: `B x G` correlation lengths [m], or ``None`` for a kernel without length.
        sigma_m: multiplicative model error (dimensionless), >= 0: a number or a `B` tensor.
        method: ``"auto"``, ``"dense"`` or ``"state_space"`` for every block.
        extra_variance: `B x L x n` variance [µε²] added to each reading's diagonal (e.g. an
            emulator's predictive variance of ``eta``), or None.
        sigma_e_scale: `B` factors on every block's noise sd (an inferred noise level), or None.
        state_space_from: with ``method="auto"``, take the exact O(n) state space for 1-D
            blocks of a Markov kernel from this many points (None: the likelihood's own
            threshold, tuned for one parameter vector; a large batch gains from far fewer).

    Returns:
        `B` log-likelihoods (float64); -inf or NaN as :func:`log_likelihood` gives them.
    """
    kern = get_kernel(kernel)
    total = None
    for block in blocks:
        yb = y[block.loads][:, block.points]
        eb = eta[:, block.loads][:, :, block.points]
        ell = None if length is None else length[:, block.group]
        sa = sigma_a[:, block.group]
        extra = None if extra_variance is None else extra_variance[:, block.loads][:, :, block.points]
        noise = block.sigma_e if sigma_e_scale is None else block.sigma_e * sigma_e_scale
        form = method
        if (method == "auto" and state_space_from is not None and block.x.ndim == 1
                and block.sigma_e > 0 and is_markov(kern) and block.points.numel() >= state_space_from):
            form = "state_space"
        value = log_likelihood(yb, eb, block.x, kern, sa, ell, sigma_m, noise, form, extra)
        total = value if total is None else total + value
    if total is None:
        raise ValueError("likelihood blocks: no block (no valid reading)")
    return total

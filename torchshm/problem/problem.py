"""A Bayesian identification problem: forward model, measurements, kernel and priors.

``Problem.log_joint`` is the unnormalised log posterior handed to VBMC or emcee. Each distinct
physical parameter vector is sent to the forward model once per ``Problem`` (outputs are cached
under their 12-significant-digit key) and, when a store is given, once ever: the store persists
every evaluation and is consulted before the model is called.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from os import PathLike
from typing import TYPE_CHECKING, Any

import numpy as np
import torch
from torch import Tensor

from torchshm.data.positions import match_positions
from torchshm.kernels import Kernel, get_kernel
from torchshm.arrays import as_float64, as_numpy
from torchshm.likelihood.blocks import blocks_log_likelihood, make_blocks
from torchshm.priors import Prior
from torchshm.problem.matching import match_measured
from torchshm.problem.noise import NoiseLevels, default_priors
from torchshm.problem.parameters import ParameterSplit, read_priors
from torchshm.problem.prior import JointPrior
from torchshm.storage.cached_model import CachedModel

if TYPE_CHECKING:
    from torchshm.forward.protocol import ForwardModel
    from torchshm.data.measurements import Measurements


class Problem:
    """Likelihood of Eq. (21) and priors of one identification problem.

    Args:
        model: forward model ``model(theta_p) -> ... x L_model x n_model`` [µε] with attributes
            ``x`` and ``loads`` (and optionally ``names``, its parameter names, and ``line``,
            `n_model` line labels beside ``x`` for a model of several sensor lines).
        measurements: a :class:`~torchshm.data.Measurements` (``x``, ``y``, ``loads``,
            ``sigma_e``, ``line``, ``mask``); its loads must be among the model's (within
            1e-6 m), its positions too (``match``). Each line's valid readings of a load case
            are one independent block of Eq. (21) (:mod:`torchshm.likelihood.blocks`); masked
            readings are left out of their own load case's block.
        kernel: discrepancy kernel name (:data:`torchshm.kernels.KERNELS`) or instance.
        priors: name -> :class:`~torchshm.priors.Prior` or a number (fixes the parameter);
            ``None`` means the model's own, ``model.default_priors()`` (bridge 705's model and
            shipped surrogate give the paper's); a model without them needs priors. Entries
            other than ``sigma_a`` and ``length`` are the physical parameters, passed to the
            model in this order (in ``model.names`` order when the model declares names). A
            ``length`` entry is dropped for a kernel without length.
        sigma_m: standard deviation of the multiplicative model error, >= 0; or a prior (e.g.
            ``Uniform(0, 0.2)``), which makes ``sigma_m`` an inferred parameter (after the
            discrepancy's) so the data decide how much of the misfit scales with the strains.
            A ``sigma_m`` entry in ``priors`` does the same.
        sigma_e: measurement noise [µε], >= 0, for every line; ``None`` means
            ``measurements.sigma_e`` (per line when the measurements give one per line); or a
            prior, which makes ``sigma_e`` [µε] (one level for every line) inferred.
        store: path of an evaluation store or an ``EvaluationStore``; every model evaluation
            goes through :func:`torchshm.storage.evaluate` and is persisted there. ``None``
            keeps the evaluations in this process (:mod:`torchshm.storage.cache`).
        match: how measured positions map onto the model's, line by line: ``"exact"`` (each
            is one of the model's on its line, within 1e-6 m) or ``"interpolate"`` (linear
            interpolation along the line, no extrapolation); see :mod:`torchshm.problem.matching`.
        discrepancy: ``"shared"`` (one σa and l for every line) or ``"per_line"`` (parameters
            ``sigma_a[<line>]`` and ``length[<line>]``; a prior given for ``sigma_a`` or
            ``length`` serves every line without its own entry).

    Attributes:
        names: the `D` inferred parameters (physical first, then ``sigma_a`` [, ``length``]).
        physical_names: the `P` physical parameters in model order (fixed ones included).
        split: the :class:`~torchshm.problem.ParameterSplit` of a parameter vector into the
            model's ``theta_p`` and the discrepancy's ``sigma_a``, ``length`` (fixed values
            filled in).
        prior: the :class:`~torchshm.problem.JointPrior` of the inferred parameters (log
            density, draws, bounds).

    Raises:
        ValueError: naming the problem: unknown kernel, measured load cases or positions the
            model does not produce, negative ``sigma_m`` or ``sigma_e``, or a bad priors entry.
    """

    def __init__(
        self,
        model: ForwardModel,
        measurements: Measurements,
        kernel: str | Kernel = "matern32",
        priors: Mapping[str, Prior | float] | None = None,
        sigma_m: float | Prior = 0.05,
        sigma_e: float | Prior | None = None,
        store: str | PathLike[str] | Any | None = None,
        *,
        match: str = "exact",
        discrepancy: str = "shared",
    ) -> None:
        self.model = model
        self.measurements = measurements
        if discrepancy not in ("shared", "per_line"):
            raise ValueError(f"Problem: discrepancy must be 'shared' or 'per_line', got {discrepancy!r}")
        self.kernel = get_kernel(kernel)
        given = dict(default_priors(model) if priors is None else priors)
        lines = list(measurements.line_slices()) if hasattr(measurements, "line_slices") else [None]
        noise = NoiseLevels.read(given, sigma_m, sigma_e, measurements, lines)  # takes the noise entries
        self.sigma_m, self.sigma_e, base = noise.sigma_m, noise.sigma_e, noise.base
        groups = lines if discrepancy == "per_line" and lines != [None] else []
        self.priors, self.physical_names = read_priors(given, self.kernel, getattr(model, "names", None), groups)
        self.priors.update(noise.priors)
        self.split = ParameterSplit.from_priors(
            self.priors, self.physical_names, self.kernel.has_length, groups
        )
        self.names = list(self.split.names)
        self.prior = JointPrior(self.priors, self.names)
        self.load_index = match_positions(measurements.loads, as_numpy(model.loads), "load case")
        self.positions = match_measured(measurements, model, match)
        self._y = torch.as_tensor(np.asarray(measurements.y, dtype=np.float64))
        self._x = torch.as_tensor(np.asarray(measurements.x, dtype=np.float64))
        mask = getattr(measurements, "mask", np.ones(self._y.shape, dtype=bool))
        slices = getattr(measurements, "line_slices", lambda: {None: slice(0, self._x.shape[0])})()
        self.blocks = make_blocks(
            self._x, mask, slices, base, {g: i for i, g in enumerate(groups)} if groups else None
        )
        self._model = CachedModel(model, store)

    @property
    def x_index(self) -> np.ndarray:
        """`n` indices into ``model.x`` of the measured positions (``match="exact"`` only).

        Raises:
            ValueError: when the positions are interpolated (use :meth:`at_measured`).
        """
        if not self.positions.exact:
            raise ValueError("Problem.x_index: positions are interpolated (match='interpolate'); use at_measured()")
        return self.positions.left

    @property
    def y(self) -> Tensor:
        """`L x n` measured strains [µε] (masked readings as the measurements hold them)."""
        return self._y

    def noise_of(self, rows: Tensor) -> tuple[float | Tensor, str, None, Tensor | None]:
        """Arguments ``(sigma_m, method, extra_variance, sigma_e_scale)`` of
        :func:`~torchshm.likelihood.blocks.blocks_log_likelihood` for parameter rows `B x D`:
        the fixed σm or its `B` inferred values, and the inferred σe [µε] (the blocks then
        hold a noise level of 1) or None."""
        fixed_m = 0.0 if hasattr(self.sigma_m, "log_prob") else float(self.sigma_m)
        scale = self.split.noise(rows, "sigma_e", 1.0)
        return (self.split.noise(rows, "sigma_m", fixed_m), "auto", None,
                scale if isinstance(scale, Tensor) else None)

    @property
    def n_lines(self) -> int:
        """Number of measured sensor lines."""
        return len({b.line for b in self.blocks})

    def at_measured(self, outputs: Tensor) -> Tensor:
        """Model strains `B x L x n` at the measured load cases and positions from outputs
        `B x L_model x n_model` [µε] (exact or interpolated, :attr:`positions`)."""
        return self.positions.apply(outputs[:, self.load_index])

    # ------------------------------------------------------------------ bounds and prior
    @property
    def hard_bounds(self) -> np.ndarray:
        """`D x 2` hard bounds of the inferred parameters, in :attr:`names` order."""
        return self.prior.hard_bounds

    @property
    def search_bounds(self) -> np.ndarray:
        """`D x 2` box the methods search: :attr:`hard_bounds` with the open end of a one-sided
        prior closed at its 1 - 1e-12 quantile (:attr:`JointPrior.search_bounds`)."""
        return self.prior.search_bounds

    @property
    def plausible_bounds(self) -> np.ndarray:
        """`D x 2` plausible bounds of the inferred parameters, in :attr:`names` order."""
        return self.prior.plausible_bounds

    def sample_prior(self, n: int, rng: np.random.Generator | int | None = None) -> np.ndarray:
        """`n x D` independent draws from the prior (:attr:`prior`)."""
        return self.prior.sample(n, rng)

    def log_prior(self, theta: object) -> Tensor | np.ndarray:
        """Log prior density `...` of ``theta`` (`... x D`); -inf outside the support."""
        flat, shape, is_torch = self._flatten(theta)
        return _result(self._log_prior(flat), shape, is_torch)

    # ------------------------------------------------------------------ likelihood
    def log_likelihood(self, theta: object) -> Tensor | np.ndarray:
        """Log-likelihood (Eq. 21) `...` of ``theta`` (`... x D`); -inf outside the hard bounds."""
        flat, shape, is_torch = self._flatten(theta)
        lo, hi = (torch.as_tensor(b) for b in self.hard_bounds.T)
        inside = ((flat >= lo) & (flat <= hi)).all(-1)
        return _result(self._where_rows(flat, inside, self._log_likelihood), shape, is_torch)

    def log_joint(self, theta: object) -> Tensor | np.ndarray:
        """Unnormalised log posterior `...` of ``theta`` (`... x D`), numpy or torch.

        -inf (never NaN, never an exception) outside the prior support or where the model
        output is not finite; the model is only evaluated where the prior density is positive.
        """
        flat, shape, is_torch = self._flatten(theta)
        prior = self._log_prior(flat)
        ok = torch.isfinite(prior)
        value = prior + self._where_rows(flat, ok, self._log_likelihood)
        return _result(torch.where(ok, value, -torch.inf), shape, is_torch)

    def _log_prior(self, flat: Tensor) -> Tensor:
        return self.prior.log_prob(flat)  # type: ignore[return-value]

    def _log_likelihood(self, rows: Tensor) -> Tensor:
        """Log-likelihoods `B` of parameter vectors `B x D` inside the support."""
        theta_p = self.split.physical(rows)
        sigma_a, length = self.split.discrepancy(rows)
        eta = self.at_measured(self.model_outputs(theta_p))
        finite = torch.isfinite(eta).all(-1).all(-1)
        eta = torch.where(finite[:, None, None], eta, 0.0)
        value = blocks_log_likelihood(self._y, eta, self.blocks, self.kernel, sigma_a, length,
                                      *self.noise_of(rows))
        return torch.where(finite, _nan_to_neg_inf(value), -torch.inf)

    def _where_rows(self, flat: Tensor, mask: Tensor, fn: Any) -> Tensor:
        """``fn(flat[mask])`` on the masked rows, -inf on the others (differentiable)."""
        out = torch.full((flat.shape[0],), -math.inf, dtype=flat.dtype)
        if bool(mask.any()):
            idx = mask.nonzero(as_tuple=True)
            out = out.index_put(idx, fn(flat[idx]))
        return out

    # ------------------------------------------------------------------ parameters
    def _flatten(self, theta: object) -> tuple[Tensor, tuple[int, ...], bool]:
        is_torch = isinstance(theta, Tensor)
        t = as_float64(theta)
        if t.ndim == 0 or t.shape[-1] != len(self.names):
            d = len(self.names)
            raise ValueError(
                f"theta must have shape (..., {d}) for {self.names}, got {tuple(t.shape)}"
            )
        return t.reshape(-1, len(self.names)), tuple(t.shape[:-1]), is_torch

    # ------------------------------------------------------------------ model evaluations
    @property
    def store(self) -> Any:
        """The ``EvaluationStore`` every model evaluation goes through, or ``None``."""
        return self._model.store

    def with_store(self, store: str | PathLike[str] | Any) -> Problem:
        """This problem, its evaluations kept from now on in ``store`` (a path or an
        ``EvaluationStore``); the runs it made before are copied there. Parallel runs
        (``n_jobs``, an executor) need a store, where each worker leaves its result.

        Raises:
            ValueError: when the problem has a store already.
        """
        self._model.attach_store(store)
        return self

    @property
    def n_model_evaluations(self) -> int:
        """Model calls made by this problem (cache and store hits excluded)."""
        return self._model.n_evaluations

    def model_outputs(self, theta_p: object) -> Tensor:
        """Model strains `... x L_model x n_model` [µε] for physical parameters `... x P`.

        Each distinct vector (to 12 significant digits) is evaluated once per ``Problem``, or
        once per store with a store; NaN where a run failed. A tensor that requires grad keeps
        its graph through the model when no store is used (see :class:`CachedModel`).
        """
        return self._model(theta_p)

    def evaluations(self) -> tuple[np.ndarray, np.ndarray]:
        """``(theta_p (M, P), outputs (M, L_model, n_model))`` of every finished evaluation
        this problem has made or found in its store (failed runs excluded)."""
        return self._model.evaluations(len(self.physical_names))

    def failures(self) -> tuple[np.ndarray, list[str]]:
        """``(theta_p (F, P), errors)``: the failed model runs of this problem (or of its store)
        and their error texts, oldest first."""
        return self._model.failures()

    def __repr__(self) -> str:
        return (
            f"Problem(kernel={self.kernel.name!r}, names={self.names}, "
            f"loads={len(self.load_index)}, n={self._x.shape[0]})"
        )


def _nan_to_neg_inf(value: Tensor) -> Tensor:
    return torch.where(torch.isnan(value), -torch.inf, value)


def _result(value: Tensor, shape: tuple[int, ...], is_torch: bool) -> Tensor | np.ndarray:
    value = value.reshape(shape)
    return value if is_torch else value.detach().numpy()[()]

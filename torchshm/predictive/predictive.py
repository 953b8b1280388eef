"""Posterior predictive distribution without new model evaluations (paper, Sec. 2.4.1).

The paper's extension of VBMC, step by step:

1. take the model outputs that inference already computed, at every `theta_p` it evaluated,
   for all load cases of the model (``problem.evaluations()``);
2. fit a zero-mean GP emulator with shared hyperparameters to the outputs at the prediction
   load cases and positions (:mod:`torchshm.predictive.emulator`);
3. sample `theta` from the posterior, emulate the model response `eta~` at its physical part,
   adding the emulator's own uncertainty when it is not negligible next to ``sigma_e**2``;
4. draw `y~ ~ N(eta~, sigma_m**2 diag(eta~)**2 + K~ + sigma_e**2 I)` per load case and sensor
   line (:mod:`torchshm.predictive.draws`) and summarise the draws.

Positions are the problem's one view of the data (:mod:`torchshm.predictive.view`): the
measured points of every line (exact or interpolated positions, `n x d` coordinates of a
field) or the model's own positions; the emulator is fitted to the stored outputs mapped onto
those points.

Steps 3 and 4 run in chunks of posterior draws (:mod:`torchshm.predictive.chunks`,
:mod:`torchshm.predictive.phases`) with the random numbers of all draws at once, so memory holds
the result's arrays and a few chunks; a request that would not fit is refused before step 2
(:mod:`torchshm.predictive.memory`).

:func:`exact_predictive` follows the same steps with the same random numbers but evaluates the
model itself in step 3 (once, for every draw: its outputs are held whole); it exists to check
the emulator and costs `n` model evaluations.
"""

from __future__ import annotations

import logging
import time
from typing import TYPE_CHECKING, Any, Iterable, Literal

import numpy as np
import torch
from torch import Tensor

from torchshm.kernels import get_kernel
from torchshm.predictive.chunks import DrawStore, add_emulator_noise, fill_responses, row_chunks
from torchshm.predictive.emulator import fit_emulator, transform_options
from torchshm.predictive.memory import check_memory
from torchshm.predictive.phases import draw_lines
from torchshm.predictive.result import PredictiveResult
from torchshm.predictive.selection import load_index, parameter_columns, problem_of, random_streams
from torchshm.predictive.view import PredictionView, prediction_view
from torchshm.surrogate import Surrogate

if TYPE_CHECKING:
    from torchshm.forward.protocol import ForwardModel
    from torchshm.inference.protocol import PosteriorLike
    from torchshm.problem import Problem

logger = logging.getLogger(__name__)

#: the emulator variance counts when its largest value exceeds this share of ``sigma_e**2``
SURROGATE_VARIANCE_RATIO = 0.01
#: largest number of stored evaluations the emulator is trained on (a random subset beyond)
MAX_TRAINING_POINTS = 400

Positions = Literal["measured", "model"]
Keep = Literal["draws", "summary"]


def posterior_predictive(
    post: PosteriorLike,
    loads: Iterable[float] | float,
    n: int = 2000,
    seed: int = 0,
    include_surrogate_variance: bool | Literal["auto"] = "auto",
    positions: Positions = "measured",
    problem: Problem | None = None,
    level: float = 0.95,
    emulator_options: dict[str, Any] | None = None,
    keep: Keep = "draws",
) -> PredictiveResult:
    """Posterior predictive strains at load cases, with no new model evaluations.

    The draws are made in chunks of posterior draws (:mod:`torchshm.predictive.chunks`): the
    result's arrays and a few chunks are all it holds, and it refuses, before fitting the
    emulator, a request that would need more than half of the machine's memory
    (:func:`~torchshm.predictive.memory.predictive_memory`).

    Args:
        post: a posterior (``names``, ``sample(n, rng)``, ``problem``), from VBMC or emcee.
        loads: `L'` load cases to predict (front-axle positions [m]), inferred ones or not.
        n: number of posterior draws.
        seed: seed of the posterior draws and the noise draws (and of the training subset).
        include_surrogate_variance: ``True`` or ``False`` to force; ``"auto"`` adds the emulator
            variance when its largest value at the draws exceeds
            ``SURROGATE_VARIANCE_RATIO * sigma_e**2`` (the smallest line's ``sigma_e``).
        positions: ``"measured"`` for the problem's measured points (every line; positions
            interpolated as the problem does; `n x d` coordinates of a field), ``"model"`` for
            all positions of the forward model (with its ``line`` labels).
        problem: the problem to use instead of ``post.problem`` (e.g. for a loaded posterior).
        level: probability content of the equal-tailed interval.
        emulator_options: keywords of :func:`~torchshm.predictive.emulator.fit_emulator`
            (``transform``, ``kernel``, ...) overriding the defaults.
        keep: ``"draws"`` keeps the float64 draws ``samples`` and responses ``eta``;
            ``"summary"`` keeps the draws as float32 and no ``eta`` (a quarter of the memory;
            mean and bounds equal the float64 ones to float32 round-off).

    Returns:
        A :class:`PredictiveResult` with `L' x n_x` mean and bounds, `n x L' x n_x` draws, the
        points' ``x`` (`n_x` or `n_x x d`) and ``line`` labels.

    Raises:
        ValueError: without a problem, without stored evaluations (e.g. an emcee run whose
            problem kept no outputs), for an unknown load case or a bad option, or draws that
            would not fit in memory (naming the need and the fix).
    """
    if include_surrogate_variance not in ("auto", True, False):
        raise ValueError(f"include_surrogate_variance must be 'auto', True or False, got {include_surrogate_variance!r}")
    problem = problem_of(post, problem)
    view = prediction_view(problem, positions)
    n_loads = len(load_index(problem.model, loads))
    check_memory(view, n_loads, n, keep, problem.kernel)  # before the emulator's fit
    emulator = _emulator(problem, view, loads, seed, emulator_options)
    loads_t = emulator.loads
    streams = random_streams(seed)
    theta = np.asarray(post.sample(n, streams.theta), dtype=np.float64)
    theta_p, sigma_a, length = parameter_columns(problem, list(post.names), theta)
    theta_p = torch.as_tensor(theta_p)

    def source(rows: slice) -> tuple[Tensor, Tensor]:
        with torch.no_grad():
            return emulator.predict(theta_p[rows])

    store = DrawStore.empty((n, len(loads_t), view.x.shape[0]), keep)
    chunks = row_chunks(n, len(loads_t) * view.x.shape[0])
    forced = streams.emulator if include_surrogate_variance is True else None
    max_sd = fill_responses(store, chunks, source, forced)
    sigma_m, sigma_e_scale = _noise_levels(problem, theta)
    if include_surrogate_variance == "auto":
        smallest = min(part.sigma_e for part in view.parts)  # the quietest line decides
        if sigma_e_scale is not None:  # an inferred σe: its smallest draw
            smallest *= float(sigma_e_scale.min())
        used = max_sd**2 > SURROGATE_VARIANCE_RATIO * smallest**2
        if used:
            add_emulator_noise(store, chunks, source, streams.emulator)
    else:
        used = bool(include_surrogate_variance)
    logger.info("posterior predictive: drawing %d strain fields at %d load case(s) in %d chunk(s)",
                n, len(loads_t), len(chunks))
    _draw(problem, view, store, theta, sigma_a, length, streams.noise, chunks)
    return PredictiveResult.from_draws(
        store.out, view.x, loads_t, level, theta, list(post.names), store.eta, used, max_sd,
        int(emulator.theta_p.shape[0]), line=view.line,
    )


def exact_predictive(
    post: PosteriorLike,
    loads: Iterable[float] | float,
    n: int = 2000,
    seed: int = 0,
    positions: Positions = "measured",
    problem: Problem | None = None,
    model: ForwardModel | None = None,
    level: float = 0.95,
) -> PredictiveResult:
    """Posterior predictive with the model evaluated at every draw (costs `n` model runs).

    Uses the same posterior draws and noise draws as :func:`posterior_predictive` with the same
    ``seed``, so the two differ only by the emulator error. Arguments as there; ``model``
    defaults to ``problem.model`` (any callable ``theta_p (n x P) -> n x L_model x n_model``).
    """
    problem = problem_of(post, problem)
    model = problem.model if model is None else model
    loads_idx = load_index(problem.model, loads)
    view = prediction_view(problem, positions)
    streams = random_streams(seed)
    theta = np.asarray(post.sample(n, streams.theta), dtype=np.float64)
    theta_p, sigma_a, length = parameter_columns(problem, list(post.names), theta)
    with torch.no_grad():
        out = torch.as_tensor(model(torch.as_tensor(theta_p)), dtype=torch.float64)
    store = DrawStore.empty((n, len(loads_idx), view.x.shape[0]), "draws")
    chunks = row_chunks(n, len(loads_idx) * view.x.shape[0])
    fill_responses(store, chunks, lambda rows: (view.apply(out[rows][:, loads_idx]), None))
    del out
    logger.info("posterior predictive: drawing %d strain fields at %d load case(s)", n, len(loads_idx))
    _draw(problem, view, store, theta, sigma_a, length, streams.noise, chunks)
    return PredictiveResult.from_draws(
        store.out, view.x, _loads_tensor(problem.model, loads_idx), level, theta, list(post.names),
        store.eta, False, 0.0, 0, line=view.line,
    )


def stored_emulator(
    problem: Problem,
    loads: Iterable[float] | float,
    positions: Positions = "measured",
    seed: int = 0,
    emulator_options: dict[str, Any] | None = None,
) -> Surrogate:
    """The GP emulator of the problem's stored outputs at ``loads`` and ``positions``.

    Args:
        problem: the problem whose ``evaluations()`` train the emulator (no model is called).
        loads, positions, seed, emulator_options: as :func:`posterior_predictive`.

    Returns:
        A :class:`~torchshm.surrogate.Surrogate` whose ``x`` and ``loads`` are the prediction
        points and load cases (for `n x d` coordinates ``x`` is the point number 0..n-1),
        trained on at most MAX_TRAINING_POINTS stored evaluations.
    """
    return _emulator(problem, prediction_view(problem, positions), loads, seed, emulator_options)


def _emulator(problem: Problem, view: PredictionView, loads: Iterable[float] | float, seed: int,
              emulator_options: dict[str, Any] | None) -> Surrogate:
    """:func:`stored_emulator` at the points of ``view``."""
    loads_idx = load_index(problem.model, loads)
    theta_train, outputs = _training_data(problem, loads_idx, view, seed)
    options = {"transform": transform_options(problem.model),
               "names": list(problem.physical_names), **(emulator_options or {})}
    t0 = time.perf_counter()
    logger.info("posterior predictive: fitting the emulator to %d stored model runs "
                "(%d load case(s) x %d positions)", *outputs.shape)
    # the Surrogate keeps `n` positions; points of a field are given by their number
    x = view.x if view.x.ndim == 1 else torch.arange(view.x.shape[0], dtype=torch.float64)
    emulator = fit_emulator(theta_train, outputs, x, _loads_tensor(problem.model, loads_idx), **options)
    logger.info("posterior predictive: emulator fitted in %.1f s", time.perf_counter() - t0)
    return emulator


def _training_data(problem: Problem, loads_idx: Tensor, view: PredictionView, seed: int
                   ) -> tuple[Tensor, Tensor]:
    """Stored `theta_p` (`M x P`) and outputs at the points (`M x L' x n_x`), at most
    MAX_TRAINING_POINTS."""
    theta_p, outputs = problem.evaluations()
    theta_p = torch.as_tensor(np.asarray(theta_p), dtype=torch.float64)
    outputs = torch.as_tensor(np.asarray(outputs), dtype=torch.float64)
    if theta_p.ndim != 2 or theta_p.shape[0] == 0:
        raise ValueError(
            "posterior_predictive: the problem holds no stored model evaluations; pass the Problem "
            "that inference ran on (it keeps its outputs in memory) or one on the run's store"
        )
    if theta_p.shape[0] > MAX_TRAINING_POINTS:
        keep = np.random.default_rng(seed).choice(theta_p.shape[0], MAX_TRAINING_POINTS, replace=False)
        keep = torch.as_tensor(np.sort(keep))
        theta_p, outputs = theta_p[keep], outputs[keep]
    return theta_p, view.apply(outputs[:, loads_idx])


def _draw(problem: Problem, view: PredictionView, store: DrawStore, theta: np.ndarray, sigma_a: Tensor,
          length: Tensor | None, generator: torch.Generator, chunks: list[slice]) -> None:
    """The stored responses become predictive draws `n x L' x n_x`, line by line, with the
    problem's kernel, ``sigma_m`` and each line's ``sigma_e`` (per posterior draw `theta`
    `n x D` where they are inferred)."""
    sigma_m, sigma_e_scale = _noise_levels(problem, theta)
    draw_lines(store.out, view, get_kernel(problem.kernel), sigma_a, length, sigma_m, generator,
               chunks, sigma_e_scale)


def _noise_levels(problem: Problem, theta: np.ndarray) -> tuple[float | Tensor, Tensor | None]:
    """σm (a number, or `n` inferred values) and the `n` inferred σe factors (or None) of the
    posterior draws ``theta`` `n x D` (:meth:`Problem.noise_of`; a problem-like object without
    it has fixed levels)."""
    if not hasattr(problem, "noise_of"):
        return float(problem.sigma_m), None
    sigma_m, _, _, sigma_e_scale = problem.noise_of(torch.as_tensor(theta))
    return sigma_m, sigma_e_scale


def _loads_tensor(model: ForwardModel, loads_idx: Tensor) -> Tensor:
    return torch.as_tensor(model.loads, dtype=torch.float64)[loads_idx]

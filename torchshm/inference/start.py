"""Where VBMC starts: a short search for the posterior mode, and the points handed to PyVBMC.

Thousands of dense data points make the log joint span many orders of magnitude across the
plausible box (e.g. -1e2 near the mode, -1e6 at a corner). A Gaussian process fitted to such
values describes the peak poorly, and PyVBMC's default initial design (uniform in the plausible
box) puts most of its first points in that flat, extremely low region (PyVBMC issue #99;
output warping and noise shaping, MATLAB VBMC's remedies, are not ported to PyVBMC).

The remedy here, with few model evaluations:

1. a Latin hypercube design of ``n_design`` points in the plausible box (PyVBMC's own initial
   design size, ``fun_eval_start``), evaluated as one batch;
2. a Nelder-Mead search for the mode from the best design point, in coordinates scaled by the
   plausible box, limited to ``n_local`` evaluations;
3. a probe of the local scale around the best point: along each parameter, a step that starts
   at 5 % of the plausible width and shrinks fourfold until the log joint drops by at most
   ``10 D`` nats (PyVBMC's ``warmup_keep_threshold``), then the opposite step: a star design of
   ``2 D`` points at the scale of the posterior, however narrow it is;
4. VBMC then starts from there: the best point, its star and the next best points form its
   initial design (``fun_eval_start`` points, so VBMC spends no evaluation on a design of its
   own), and only points within ``keep_threshold`` nats of the best are given to its Gaussian
   process.

Every evaluation of the search is a real evaluation of the log joint: it is stored, counted and
handed to VBMC, so nothing is spent twice.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import minimize
from scipy.stats import qmc

from torchshm.inference.target import LogJointTarget

#: largest number of step reductions per parameter when probing the local scale
PROBE_TRIES = 5
#: first probing step, as a fraction of the plausible width, and its reduction factor
PROBE_FIRST, PROBE_SHRINK = 0.05, 4.0


@dataclass(frozen=True, eq=False)
class StartSettings:
    """Settings of the mode search that precedes VBMC.

    Attributes:
        n_design: Latin hypercube points in the plausible box (None: PyVBMC's
            ``fun_eval_start``, ``10 * ceil((D + 1) / 10)``).
        n_local: largest number of Nelder-Mead evaluations (None: ``10 * D``); 0 skips it.
        probe: whether to probe the local scale around the best point (at most
            ``PROBE_TRIES + 1`` evaluations per parameter) for VBMC's initial design.
        keep_threshold: points with a log joint more than this many nats below the best are not
            given to VBMC (None: ``100 * (D + 2)``, PyVBMC's ``warmup_keep_threshold_false_alarm``).
        points: extra starting points `N x D` of the user's, evaluated with the design.
    """

    n_design: int | None = None
    n_local: int | None = None
    probe: bool = True
    keep_threshold: float | None = None
    points: np.ndarray | None = None

    def resolved(self, dim: int, budget: int | None = None) -> StartSettings:
        """Settings with every None replaced by its default for dimension ``dim``; with an
        evaluation ``budget`` (PyVBMC's ``max_fun_evals``) the search takes at most half of it."""
        n_design = self.n_design if self.n_design is not None else 10 * -(-(dim + 1) // 10)
        n_local = self.n_local if self.n_local is not None else 10 * dim
        probe = self.probe
        if budget is not None:
            n_design = min(n_design, budget // 2)
            probe = probe and n_design + dim * (PROBE_TRIES + 1) <= budget // 2
            probes = dim * (PROBE_TRIES + 1) if probe else 0
            n_local = min(n_local, max(0, budget // 2 - n_design - probes))
        threshold = self.keep_threshold if self.keep_threshold is not None else 100.0 * (dim + 2)
        return replace(
            self, n_design=n_design, n_local=n_local, probe=probe, keep_threshold=threshold
        )


def vbmc_budget(dim: int, options: dict) -> int:
    """The evaluation budget of a VBMC run with ``options``, checked before any model run.

    ``max_fun_evals`` None or absent means PyVBMC's default, ``50 * (2 + D)``. The start-up
    search takes up to half of the budget and PyVBMC's initial design needs ``fun_eval_start``
    runs, so a budget below ``2 * fun_eval_start`` cannot work.

    Raises:
        ValueError: naming ``max_fun_evals`` (``method.max_fun_evals`` in the config) when it is
            not an integer or too small for ``dim`` parameters.
    """
    value = options.get("max_fun_evals")
    if value is None:
        return 50 * (2 + dim)
    n_initial = options.get("fun_eval_start") or 10 * -(-(dim + 1) // 10)
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"max_fun_evals (method.max_fun_evals) must be an integer, got {value!r}")
    if value < 2 * int(n_initial):
        raise ValueError(
            f"max_fun_evals (method.max_fun_evals) must be at least {2 * int(n_initial)} for "
            f"{dim} parameters (the start-up search takes up to half of it and PyVBMC's initial "
            f"design needs fun_eval_start = {int(n_initial)} runs), got {value}"
        )
    return int(value)


def latin_design(plausible: np.ndarray, n: int, seed: int) -> np.ndarray:
    """``n`` Latin hypercube points in the plausible box ``plausible`` (`D x 2`) -> `n x D`."""
    if n <= 0:
        return np.zeros((0, plausible.shape[0]))
    sampler = qmc.LatinHypercube(d=plausible.shape[0], seed=np.random.default_rng([seed, 5]))
    unit = sampler.random(n)
    return plausible[:, 0] + unit * (plausible[:, 1] - plausible[:, 0])


def local_search(
    target: LogJointTarget, x_start: np.ndarray, plausible: np.ndarray, hard: np.ndarray,
    max_evals: int,
) -> None:
    """Nelder-Mead ascent of the log joint from ``x_start``, at most ``max_evals`` evaluations.

    The search runs in coordinates scaled by the plausible box (initial simplex: steps of 10 %
    of the box), and stays strictly inside the hard bounds (points outside count as -inf
    without an evaluation). Every evaluation is recorded by ``target``.
    """
    if max_evals <= 0:
        return
    lo, width = plausible[:, 0], plausible[:, 1] - plausible[:, 0]
    budget = {"left": int(max_evals)}

    def objective(u: np.ndarray) -> float:
        theta = lo + u * width
        if np.any(theta <= hard[:, 0]) or np.any(theta >= hard[:, 1]) or budget["left"] <= 0:
            return np.inf
        budget["left"] -= 1
        value = float(target.evaluate(theta[None, :])[0])
        return -value if np.isfinite(value) else np.inf

    u0 = (x_start - lo) / width
    simplex = np.vstack([u0, u0 + 0.1 * np.eye(len(u0))])
    minimize(
        objective, u0, method="Nelder-Mead",
        options={"initial_simplex": simplex, "maxfev": int(max_evals), "xatol": 1e-4,
                 "fatol": 1e-2},
    )


def probe_scales(
    target: LogJointTarget, x_best: np.ndarray, y_best: float, plausible: np.ndarray,
    hard: np.ndarray, max_drop: float,
) -> np.ndarray:
    """A star design `2D x D` around ``x_best`` at the local scale of the log joint.

    Along each parameter the step starts at 5 % of the plausible width and shrinks fourfold
    (at most ``PROBE_TRIES`` times) until the log joint at ``x_best + h e_j`` is within
    ``max_drop`` nats of ``y_best``; ``x_best - h e_j`` is then evaluated too. The steps stay
    strictly inside the hard bounds (the probe goes the other way where one is too close).
    """
    width = plausible[:, 1] - plausible[:, 0]
    star = []
    for j in range(x_best.size):
        h = PROBE_FIRST * width[j]
        for attempt in range(PROBE_TRIES + 1):
            plus, minus = x_best.copy(), x_best.copy()
            plus[j], minus[j] = x_best[j] + h, x_best[j] - h
            if not _inside(plus, hard):
                plus, minus = minus, plus
            if _inside(plus, hard):
                value = float(target.evaluate(plus[None, :])[0])
                if y_best - value <= max_drop or attempt == PROBE_TRIES:
                    break
            h /= PROBE_SHRINK
        star.append(plus)
        if _inside(minus, hard):
            target.evaluate(minus[None, :])
            star.append(minus)
    return np.array(star).reshape(-1, x_best.size)


def _inside(theta: np.ndarray, hard: np.ndarray) -> bool:
    return bool(np.all(theta > hard[:, 0]) and np.all(theta < hard[:, 1]))


def find_start(
    target: LogJointTarget, plausible: np.ndarray, hard: np.ndarray, settings: StartSettings,
    seed: int,
) -> np.ndarray:
    """Evaluate the design, run the local search and probe the local scale.

    The local search starts from the best design point, so that, with the same seed, a rerun
    on the same store retraces the same search from stored evaluations (no model call). Without
    a design it starts from the best point known (a previous run's), else from the centre of
    the plausible box. The evaluations stay in ``target``.

    Returns:
        The best point followed by the probing star design (`(2D + 1) x D`), or `0 x D` when
        nothing finite is known.
    """
    s = settings.resolved(plausible.shape[0])
    design = latin_design(plausible, int(s.n_design or 0), seed)
    if s.points is not None:
        design = np.vstack([np.atleast_2d(np.asarray(s.points, dtype=np.float64)), design])
    values = target.evaluate(design) if design.shape[0] else np.zeros(0)
    if s.n_local:
        if np.isfinite(values).any():
            x_start = design[int(np.argmax(values))]
        else:
            X, _ = target.known()
            x_start = X[0] if X.shape[0] else plausible.mean(axis=1)
        local_search(target, x_start, plausible, hard, int(s.n_local))
    X, y = target.known()
    if X.shape[0] == 0:
        return np.zeros((0, plausible.shape[0]))
    if not s.probe:
        return X[:1]
    max_drop = 10.0 * plausible.shape[0]  # PyVBMC's warmup_keep_threshold
    return np.vstack([X[:1], probe_scales(target, X[0], float(y[0]), plausible, hard, max_drop)])


def vbmc_start(
    target: LogJointTarget, first: np.ndarray, n_initial: int, keep_threshold: float,
) -> tuple[np.ndarray | None, tuple[np.ndarray, np.ndarray] | None]:
    """Starting points and precomputed evaluations for PyVBMC from what ``target`` knows.

    Args:
        target: the evaluations made so far.
        first: points that lead the initial design (the best point and its probing star).
        n_initial: size of PyVBMC's initial design (``fun_eval_start``).
        keep_threshold: points more than this many nats below the best are left out.

    Returns:
        ``(x0, (X, y))``: up to ``n_initial`` distinct starting points (`n0 x D`): ``first``,
        then the best other known points; and every known point within ``keep_threshold`` of
        the best with its log joint (the ``x0`` rows among them, so PyVBMC evaluates none of
        them again). ``(None, None)`` when nothing is known (PyVBMC then starts from the centre
        of the plausible box).
    """
    X, y = target.known()
    if X.shape[0] == 0:
        return None, None
    keep = y >= y[0] - keep_threshold
    X, y = X[keep], y[keep]
    lead = [row for row in np.atleast_2d(first) if np.any(np.all(X == row, axis=1))]
    rest = [row for row in X if not any(np.array_equal(row, r) for r in lead)]
    x0 = np.array((lead + rest)[: max(1, int(n_initial))])
    if x0.shape[0] > 1 and np.any(np.ptp(x0, axis=0) == 0):
        x0 = x0[:1]  # a design without spread in a coordinate is refused by PyVBMC
    return x0, (X, y)

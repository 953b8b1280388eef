"""Modes of the emulated posterior, so that no chain keeps one mode of several.

emcee's walkers cannot cross a valley between two modes: a walker left in a mode that looked
worse in an early round is moved onto the others (:func:`.sampling.regroup`), and a mode no
walker ever reached stays unseen while the stop rule, which compares the chains of successive
rounds, is satisfied. So before each round's chain the emulated log joint is maximised from
several starts: the best model runs so far (their θp with the best walker's other parameters),
the best walker, a few points spread over the plausible box and the caller's (the adaptive
method passes the exploration's best Sobol points and the modes of the round before, so that a
narrow mode the walkers have left is found again while the emulator shows it). The optima are merged into
distinct modes (a valley of more than :data:`VALLEY` nats on the segment between two of them)
and the walkers are spread over the modes within :func:`.sampling.straggler_gap` of the best,
in proportion to each mode's mass (a Laplace estimate: density at the mode times the volume
of the walkers there, or of the largest mode's walkers for a new one). The chain then mixes
the modes' shares with emcee's differential-evolution move at ``gamma = 1`` (a jump by the
difference of two walkers, which carries a walker from one mode to the same place in
another), and the final density and importance sampling see every mode.

The optimisation is L-BFGS-B on the sum of the starts' negative log joints (independent
blocks, as BoTorch optimises a batch of restarts), in the plausible box's unit coordinates,
with forward-difference gradients: each evaluation is one batched call of ``S (D + 1)`` rows.
"""

from __future__ import annotations

from typing import Callable

import numpy as np
from scipy.optimize import minimize

from torchshm.inference.adaptive.sampling import straggler_gap

LogDensity = Callable[[np.ndarray], np.ndarray]

#: nats below the lower of two optima that the segment between them must dip to count as
#: two modes (the reference's rule for the suite)
VALLEY = 3.0
#: forward-difference step in the plausible box's unit coordinates
STEP = 1e-6


def find_modes(log_joint: LogDensity, starts: np.ndarray, hard: np.ndarray,
               plausible: np.ndarray, max_iter: int = 25) -> tuple[np.ndarray, np.ndarray]:
    """Local maxima of ``log_joint`` from ``starts`` `S x D`, merged into distinct modes.

    Args:
        log_joint: vectorised log density of rows `B x D` (-inf outside the support).
        starts: `S x D` starting rows (those with a non-finite density are dropped).
        hard: `D x 2` bounds of the support (infinite where open).
        plausible: `D x 2` plausible box (the optimiser's scale).
        max_iter: L-BFGS-B iterations.

    Returns:
        ``(modes, values)``: `K x D` distinct modes, best first, and their `K` log densities.
    """
    starts = np.asarray(starts, dtype=np.float64)
    values = np.asarray(log_joint(starts), dtype=np.float64)
    starts, values = starts[np.isfinite(values)], values[np.isfinite(values)]
    if starts.shape[0] == 0:
        return starts, values
    lo, width = plausible[:, 0], plausible[:, 1] - plausible[:, 0]
    n, dim = starts.shape
    bounds = [(None if not np.isfinite(a) else (a - lo[d]) / width[d] + STEP,
               None if not np.isfinite(b) else (b - lo[d]) / width[d] - STEP)
              for a, b, d in ((*hard[d], d) for d in range(dim))] * n

    def objective(flat: np.ndarray) -> tuple[float, np.ndarray]:
        u = flat.reshape(n, dim)
        step = np.where(u + STEP > np.array([b[1] if b[1] is not None else np.inf
                                               for b in bounds[:dim]]), -STEP, STEP)
        rows = np.concatenate([u[:, None, :], u[:, None, :] + np.eye(dim) * step[:, None, :]],
                              axis=1)  # n x (D + 1) x D
        f = np.asarray(log_joint((lo + rows * width).reshape(-1, dim)),
                       dtype=np.float64).reshape(n, dim + 1)
        ok = np.isfinite(f).all(axis=1)
        grad = np.where(ok[:, None], (f[:, 1:] - f[:, :1]) / step, 0.0)
        value = np.where(np.isfinite(f[:, 0]), f[:, 0], -1e10)
        return -float(value.sum()), -grad.reshape(-1)

    u0 = ((starts - lo) / width).reshape(-1)
    result = minimize(objective, u0, jac=True, method="L-BFGS-B", bounds=bounds,
                      options={"maxiter": int(max_iter), "ftol": 1e-12, "gtol": 1e-6})
    optima = lo + result.x.reshape(n, dim) * width
    found = np.asarray(log_joint(optima), dtype=np.float64)
    better = np.isfinite(found) & (found >= values)
    optima, found = np.where(better[:, None], optima, starts), np.where(better, found, values)
    return distinct(log_joint, optima, found, width)


def distinct(log_joint: LogDensity, points: np.ndarray, values: np.ndarray, scale: np.ndarray,
             n_segment: int = 7) -> tuple[np.ndarray, np.ndarray]:
    """The points `K x D` (best first) of ``points`` `S x D` that are separate modes: each is
    kept unless the segment to a better kept point never dips :data:`VALLEY` nats below the
    lower of the two (one call for every segment of every pair)."""
    order = np.argsort(-values)
    points, values = points[order], values[order]
    t = np.linspace(0.0, 1.0, n_segment + 2)[1:-1]
    pairs = [(i, j) for i in range(len(points)) for j in range(i)]
    dips = np.zeros((len(points), len(points)), dtype=bool)
    if pairs:
        a = np.array([points[j] for i, j in pairs])
        b = np.array([points[i] for i, j in pairs])
        seg = a[:, None, :] + t[None, :, None] * (b - a)[:, None, :]
        f = np.asarray(log_joint(seg.reshape(-1, points.shape[1])),
                       dtype=np.float64).reshape(len(pairs), -1)
        f[~np.isfinite(f)] = -np.inf
        for (i, j), row in zip(pairs, f):
            near = np.max(np.abs(points[i] - points[j]) / scale) < 1e-3
            dips[i, j] = not near and row.min() < min(values[i], values[j]) - VALLEY
    keep: list[int] = []
    for i in range(len(points)):
        if all(dips[i, j] for j in keep):
            keep.append(i)
    return points[keep], values[keep]


def assign(walkers: np.ndarray, modes: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """Index `W` of the nearest mode of each walker (distance in units of ``scale`` `D`)."""
    d = np.abs(walkers[:, None, :] - modes[None, :, :]) / scale
    return np.argmin(np.square(d).sum(-1), axis=1)


def spread_walkers(walkers: np.ndarray, modes: np.ndarray, values: np.ndarray, gap: float,
                   scale: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Walkers `W x D` moved so that every mode within ``gap`` nats of the best holds a share
    in proportion to its Laplace mass (``exp(value)`` times the volume of its walkers' spread;
    a mode without walkers borrows the spread of the most populated one). Unchanged with a
    single mode."""
    live = values >= values.max() - gap
    modes, values = modes[live], values[live]
    if modes.shape[0] < 2:
        return walkers
    label = assign(walkers, modes, scale)
    counts = np.bincount(label, minlength=len(modes))
    common = walkers[label == np.argmax(counts)]
    spreads = [walkers[label == k].std(axis=0) if counts[k] > 2 else common.std(axis=0)
               for k in range(len(modes))]
    spreads = [np.maximum(s, 1e-4 * scale) for s in spreads]
    log_mass = values + np.array([np.log(s).sum() for s in spreads])
    share = np.exp(log_mass - log_mass.max())
    share /= share.sum()
    want = np.floor(share * walkers.shape[0]).astype(int)
    want[np.argsort(-(share * walkers.shape[0] - want))[: walkers.shape[0] - want.sum()]] += 1
    out = walkers.copy()
    spare = [w for k in range(len(modes)) for w in np.flatnonzero(label == k)[want[k]:]]
    rng.shuffle(spare)
    for k in range(len(modes)):
        missing = int(want[k] - min(counts[k], want[k]))
        for w in spare[:missing]:
            out[w] = modes[k] + 0.1 * spreads[k] * rng.standard_normal(modes.shape[1])
        spare = spare[missing:]
    return out


def starts_from(log_joint: LogDensity, walkers: np.ndarray, runs: np.ndarray,
                columns: tuple[list[int], list[int]], plausible: np.ndarray,
                rng: np.random.Generator, n_runs: int = 3, n_spread: int = 2) -> np.ndarray:
    """Starting rows `S x D` of the mode search: the best walker, the ``n_runs`` best model runs
    (their θp in the best walker's row) and ``n_spread`` uniform points of the plausible box.

    Args:
        log_joint: vectorised log density of rows `B x D`.
        walkers: `W x D` the current walkers.
        runs: `N x P` θp of the model runs so far.
        columns: ``(row_columns, theta_columns)``: where the inferred physical parameters sit
            in a row `D` and in θp `P`.
        plausible: `D x 2` plausible box.
        rng: generator of the spread.
    """
    lp = np.asarray(log_joint(walkers), dtype=np.float64)
    best = walkers[int(np.argmax(np.where(np.isfinite(lp), lp, -np.inf)))]
    rows = np.repeat(best[None], runs.shape[0], axis=0)
    rows[:, columns[0]] = runs[:, columns[1]]
    if rows.shape[0]:
        f = np.asarray(log_joint(rows), dtype=np.float64)
        rows = rows[np.argsort(-np.where(np.isfinite(f), f, -np.inf))[:n_runs]]
    spread = plausible[:, 0] + rng.random((n_spread, plausible.shape[0])) * np.diff(plausible).T
    return np.concatenate([best[None], rows, spread])


def spread(log_joint: LogDensity, walkers: np.ndarray, runs: np.ndarray,
           columns: tuple[list[int], list[int]], hard: np.ndarray, plausible: np.ndarray,
           rng: np.random.Generator, extra: np.ndarray) -> tuple[np.ndarray, int, np.ndarray]:
    """The walkers `W x D` spread over the modes of ``log_joint`` found from the starts of
    :func:`starts_from` (``runs`` `N x P` the runs' θp) and ``extra`` `E x D`; returns the
    walkers, the number of modes that hold walkers and the modes `K x D`, best first."""
    starts = starts_from(log_joint, walkers, runs, columns, plausible, rng)
    modes, values = find_modes(log_joint, np.concatenate([starts, extra]), hard, plausible)
    if modes.shape[0] == 0:
        return walkers, 1, modes
    gap = straggler_gap(walkers.shape[1])
    walkers = spread_walkers(walkers, modes, values, gap, plausible[:, 1] - plausible[:, 0], rng)
    return walkers, max(1, int((values >= values.max() - gap).sum())), modes

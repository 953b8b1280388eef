"""Global exploration: no region of the box may hide posterior mass the emulator cannot rule out.

The batch rule (:mod:`.acquisition`) and the mode search (:mod:`.modes`) look where the emulated
posterior already is. A mode the emulator has never seen (no run near it) has an emulated log
joint far below the found one, so neither goes there and the stop rule, which compares the
chains of successive rounds, is satisfied. PyVBMC's and GPry's acquisitions have the same blind
spot: both weight the emulator's uncertainty by the emulated density (PyVBMC: the integrand's
sd ``σ(x) exp(μ(x))``; GPry: ``exp(2ζ μ(x)) σ(x)``, ζ = d^-0.85), so a region 200 nats below
the best is never visited.

Each round therefore scores a scrambled Sobol set of :data:`N_SOBOL` points of the plausible box
of the physical parameters (the other parameters those of the best walker) by
``z = (μ(x) - level) / s(x)``: ``μ`` the emulated log joint, ``level`` the best one less the
straggler gap (:func:`.sampling.straggler_gap`), ``s`` the sd of the log-likelihood that the
emulator error causes there (:meth:`EmulatedLogJoint.value_and_sd`: the exact gradient of the
likelihood, the error correlated across readings as the runs' fields are; it holds far from the
posterior too) times the emulator's record at the last exploration runs
(:func:`explore_calibration`). A point below the level is **unresolved** when ``z >= -κ``,
κ = :data:`KAPPA` (a one-sided 3-sd upper confidence bound ``μ + κ s``, which a calibrated
Gaussian error exceeds once in 740): it might hold a mode. (A second-order reading of the
same error model, :func:`.curvature.reach_chance`, is tighter far from the data but lost a mode
of the suite's ``beam3_bimodal``: measured and left off, :data:`SECOND_ORDER`.) While any point
is unresolved, one run of each batch goes to the unresolved points (:func:`exploration_batch`; once the rest of the
stop rule holds, the batch holds only the runs it waits for, one per point up to the batch) and
the stop rule does not hold, so a run that reaches its cap with an unresolved point says it did
not converge.
The best Sobol points also start the mode search, so a mode that an exploration run revealed
gets walkers. A point within :data:`NEAR` draw sds of a one-mode posterior is its flank, not a
mode (:func:`beyond_posterior`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import torch
from scipy.stats import norm, qmc

from torchshm.inference.adaptive.acquisition import choose_batch
from torchshm.inference.adaptive.curvature import reach_chance
from torchshm.inference.adaptive.sampling import straggler_gap

if TYPE_CHECKING:
    from torchshm.inference.adaptive.field import FieldEmulator
    from torchshm.inference.adaptive.likelihood import EmulatedLogJoint

#: Sobol points scored per round (a power of two)
N_SOBOL = 512
#: sds of the emulated log-likelihood in the upper confidence bound
KAPPA = 3.0
#: read the first-order bound's open points again to second order (:mod:`.curvature`) and keep
#: those whose chance to reach the level is at least ``Φ(-κ)``: off. Measured on 2026-12-02
#: (``scripts/bench_flank.py --variants second_order``, ``docs/benchmarks.md``): 19-58 % fewer
#: runs on five held-out cases of 3-6 parameters, as accurate, 155 -> 185 on ``seventh6_p4``,
#: and ``beam3_bimodal`` converged on one of its two modes (the error model is too sure far
#: from the runs, and the first-order bound's slack is what kept that mode open)
SECOND_ORDER = False
#: best Sobol points passed to the mode search as starts
N_TOP = 2
#: an unresolved point this close to a posterior draw (Euclidean, in the draws' sds of the
#: physical parameters) is the found posterior's own flank, not a separate mode
NEAR = 3.0


@dataclass(frozen=True)
class Exploration:
    """One round's global check of the box.

    Attributes:
        rows: `U x D` the unresolved points (full parameter rows), most likely first.
        z: `U` their emulated log joint's distance to the level ``best - gap``, in sds of the
            emulated log-likelihood (>= -κ).
        margin: the largest such distance over all the points outside the posterior.
        top: `T x D` the :data:`N_TOP` points of highest emulated log joint (starts of the
            mode search: a mode that an exploration run revealed is searched from there).
    """

    rows: np.ndarray
    z: np.ndarray
    margin: float
    top: np.ndarray

    @property
    def n_unresolved(self) -> int:
        """Number of unresolved Sobol points."""
        return int(self.rows.shape[0])


def explore(log_joint: EmulatedLogJoint, best: np.ndarray, columns: list[int],
            plausible: np.ndarray, rng: np.random.Generator, calibration: float = 1.0,
            n: int = N_SOBOL, kappa: float = KAPPA) -> Exploration:
    """Score a Sobol set of the plausible box by the upper bound of the emulated log joint.

    Args:
        log_joint: the round's emulated log joint.
        best: `D` the best walker's row (its value is the level of the posterior).
        columns: where the inferred physical parameters sit in a row `D`.
        plausible: `D x 2` plausible box.
        rng: generator of the Sobol scrambling.
        calibration: factor >= 1 on the sd, the emulator's record at earlier exploration runs
            (:func:`explore_calibration`).
        n: number of Sobol points.
        kappa: sds in the upper bound.

    Returns:
        The :class:`Exploration` of this round.
    """
    columns = list(columns)
    level = float(log_joint(best[None])[0]) - straggler_gap(best.shape[0])
    if not columns or not np.isfinite(level):
        return Exploration(np.zeros((0, best.shape[0])), np.zeros(0), -np.inf,
                           np.zeros((0, best.shape[0])))
    box = plausible[columns]
    unit = qmc.Sobol(len(columns), scramble=True, seed=rng).random(int(n))
    rows = np.repeat(best[None], unit.shape[0], axis=0)
    rows[:, columns] = box[:, 0] + unit * (box[:, 1] - box[:, 0])
    mean, sd = log_joint.value_and_sd(rows)
    top = rows[np.argsort(-np.where(np.isfinite(mean), mean, -np.inf))[:N_TOP]]
    level = max(level, float(mean.max()) - straggler_gap(best.shape[0]))
    outside = np.isfinite(mean) & (mean < level)
    sd = max(1.0, calibration) * np.maximum(sd, 1e-12)
    z = np.where(outside, (mean - level) / sd, -np.inf)  # sds below the level
    margin = float(z.max()) if outside.any() else -np.inf
    open_ = np.flatnonzero(z >= -kappa)
    if SECOND_ORDER and open_.size:
        chance = reach_chance(log_joint, rows[open_], level, calibration)
        open_ = open_[chance >= norm.sf(kappa)]
    open_ = open_[np.argsort(-z[open_])]
    return Exploration(rows[open_], z[open_], margin, top)


def with_modes(scan: Exploration, log_joint: EmulatedLogJoint, modes: np.ndarray,
               calibration: float, sd_tol: float, kappa: float = KAPPA) -> Exploration:
    """``scan`` with the secondary modes `K x D` of the mode search (best first) that the
    emulator has not settled added first to its unresolved points: a mode whose upper bound
    ``μ + κ s`` reaches the level of :func:`explore` while the emulator is uncertain there by
    more than ``sd_tol`` nats (a mode seen through one run may be as heavy as the best one but
    emulated far lower, so the chain would give it no walkers)."""
    if modes.shape[0] < 2:
        return scan
    mean, sd = log_joint.value_and_sd(modes[1:])
    sd = max(1.0, calibration) * np.maximum(sd, 1e-12)
    level = float(log_joint(modes[:1])[0]) - straggler_gap(modes.shape[1])
    z = (mean - level) / sd
    open_ = np.flatnonzero((z >= -kappa) & (sd > sd_tol))
    if not open_.size:
        return scan
    return Exploration(np.concatenate([modes[1:][open_], scan.rows]),
                       np.concatenate([z[open_], scan.z]), max(scan.margin, float(z.max())),
                       scan.top)


def beyond_posterior(scan: Exploration, draws: np.ndarray, columns: list[int],
                     radius: float = NEAR) -> Exploration:
    """``scan`` without the unresolved points within ``radius`` of a posterior draw, in the
    draws' sds of the physical parameters (``columns`` of `S x D` ``draws``).

    The level of :func:`explore` lies the straggler gap below the best (18 nats for 5
    parameters), so some Sobol points always fall in the thin shell around the found posterior
    where the emulated log joint just crosses the level. Such a point is on the posterior's
    own flank (the chain and the batch rule cover it, and the stop rule's ``sd_tol`` bounds
    the emulator's error there); leaving it unresolved kept the stop rule from holding for
    rounds after everything else had settled, each round spending runs next to the posterior.
    A separate mode lies several sds from every draw of the found one.
    """
    columns = list(columns)
    if scan.n_unresolved == 0 or not columns or draws.shape[0] == 0:
        return scan
    scale = np.maximum(draws[:, columns].std(0), 1e-12)
    points = torch.as_tensor(scan.rows[:, columns] / scale)
    near = torch.cdist(points, torch.as_tensor(draws[:, columns] / scale)).min(1).values
    keep = (near > radius).numpy()
    return Exploration(scan.rows[keep], scan.z[keep], scan.margin, scan.top)


def exploration_batch(scan: Exploration, emulator: FieldEmulator, theta_p: np.ndarray, k: int,
                      rng: np.random.Generator) -> np.ndarray:
    """Up to ``k`` rows `b x D` among the unresolved points (their θp ``theta_p`` `U x P`),
    chosen as the posterior batch is (:func:`.acquisition.choose_batch`, which spreads them)
    with the utility of each point the probability ``Φ(z)`` that it reaches the level."""
    if k <= 0 or scan.n_unresolved == 0:
        return scan.rows[:0]
    _, index = choose_batch(emulator, theta_p, norm.cdf(scan.z), k, rng)
    return scan.rows[index] if index.size else scan.rows[:1]


def explore_calibration(log_joint: EmulatedLogJoint, rows: np.ndarray, outputs: np.ndarray,
                        default: float = 1.0) -> float:
    """How far the emulator of the round that chose them was off at exploration runs.

    Args:
        log_joint: the emulated log joint that chose the rows (not trained on the runs).
        rows: `b x D` the exploration rows.
        outputs: `b x L x n` the runs' strains [µε] at the measured readings (NaN: failed).
        default: the value without a successful run (the last one known).

    Returns:
        ``max(1, sqrt(2 mean(max(0, e)²)))`` with ``e = (ℓ_run - μ) / s`` over the successful
        runs: the root mean square of the errors in the direction that matters (a run better
        than predicted: a region wrongly ruled out), 1 for a calibrated Gaussian error;
        ``ℓ_run`` is the log joint of the run's own strains, ``μ`` and ``s`` as in
        :func:`explore`.
    """
    ok = np.isfinite(outputs.reshape(outputs.shape[0], -1)).all(-1)
    if not ok.any():
        return default
    rows = rows[ok]
    mean, sd = log_joint.value_and_sd(rows)
    theta = torch.as_tensor(rows, dtype=torch.float64)
    run = log_joint.at(torch.as_tensor(outputs[ok], dtype=torch.float64), None, theta)
    run = run + np.asarray(log_joint.problem.log_prior(rows), dtype=np.float64).reshape(-1)
    e = (run - mean) / np.maximum(sd, 1e-12)
    e = e[np.isfinite(e)]
    if not e.size:
        return default
    return max(1.0, float(np.sqrt(2.0 * np.mean(np.square(np.maximum(e, 0.0))))))

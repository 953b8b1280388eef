"""An unconverged posterior keeps the emulator's uncertainty in it.

The posterior of the emulator method is Eq. (21) at the emulator's mean (:mod:`.likelihood`).
When the stop rule held, the emulator's error moves that posterior by less than the rule's
tolerance (the TV witness, :mod:`.witness`). When the cap ran out first, it may move it by
much more, and the plug-in posterior can be narrower than its own error: on the suite's
``beam4_bridge`` capped at 15 runs, a spring's mean lay 6.4 of its own sds from the
reference's, with an sd 0.24 of the reference's (``scripts/bench_unconverged.py``).

Such a posterior is therefore replaced by the average of the posteriors of draws of the
emulator: ``p(θ) = E_f[π(θ) exp(ℓ_f(θ)) / Z_f]``, ``ℓ_f`` Eq. (21) at a joint draw ``f`` of
the emulator over the parameter space (:func:`error_fields`: its mean plus an error field
correlated across readings as the runs' fields are and across θ as its latent GP is, times
its calibration; the error model of the stop rule's witness and sd). In practice:
:data:`N_POINTS` draws of a proposal (a mixture fitted to the plug-in posterior's draws,
widened, with slabs over the plausible box), up to :data:`N_FIELDS` joint draws of the
emulator at them (fewer where one pass of Eq. (21) over the points is slow:
:data:`BUDGET_S`), self-normalised importance weights per draw and their average. Where the
emulator is sure the result is the plug-in posterior; where it is not, the posterior is as
wide as its possible errors make it.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import torch
from scipy.special import logsumexp

from torchshm.inference.adaptive import sampling
from torchshm.inference.adaptive.mixture import fit_mixture

if TYPE_CHECKING:
    from torchshm.inference.adaptive.likelihood import EmulatedLogJoint
    from torchshm.inference.adaptive.mixture import Mixture

#: proposal points at which the error is drawn jointly (an `N x N` Cholesky factor)
N_POINTS = 1000
#: fewest effective draws of the average on :data:`N_POINTS` points: below it the average is
#: made again on more points, in proportion to reach :data:`TARGET_ESS` (at most
#: :data:`MAX_POINTS`)
MIN_ESS = 200.0
#: effective draws the average made again aims at. On an eight-parameter case capped at 600 runs
#: (``edge3_p8``, ``docs/benchmarks.md``) 1,000 points kept 106 effective draws, and the
#: average came out narrower than the plug-in posterior it should widen (a spring's sd 0.77 of
#: the reference's against 1.49); on 4,000 points, 364 effective draws, sds 0.86-1.13.
TARGET_ESS = 400.0
#: the most proposal points of the average (memory: `N x N` twice and `N x runs` per draw)
MAX_POINTS = 4000
#: joint draws of the emulator (each one an Eq. (21) evaluation at every point)
N_FIELDS = 32
#: rows per Eq. (21) call
CHUNK = 256
#: CPU seconds the draws may take, from the time of one plug-in pass over the points (at
#: least :data:`MIN_FIELDS` draws)
BUDGET_S, MIN_FIELDS = 30.0, 8
#: posterior draws and joint draws of the emulator of the stop rule's evidence sd
#: (:func:`evidence_spread`)
EVIDENCE_DRAWS, EVIDENCE_FIELDS = 300, 16
#: the rule compares the upper 95 % bound of that sd (chi-square, 15 degrees of freedom: 1.44
#: times the estimate) with ``sd_tol``: where the emulator is poor, log Z over its draws is
#: heavy-tailed and 16 draws can give a low sd by chance
EVIDENCE_UPPER = 1.44
#: widening of the proposal around the plug-in posterior (its errors may move it far)
WIDEN = 3.0
#: shares of the proposal's defensive part and of its slabs over the plausible box
DEFENSIVE, SLABS = 0.3, 0.3


class Averaged(NamedTuple):
    """The plug-in posterior averaged over the emulator's possible errors."""

    #: `n x D` draws, resampled by the averaged weights
    draws: np.ndarray
    #: effective sample size of the averaged weights (at most :data:`N_POINTS`)
    ess: float
    #: sd [nats] of the log evidence over the draws of the error
    log_z_spread: float
    #: the sd [nats] of the drawn log-likelihoods about the plug-in one, median over the
    #: points of more than median weight
    error_sd: float
    #: joint draws of the emulator averaged over
    n_fields: int
    #: proposal points of the average (:data:`N_POINTS`, more when it kept too few draws)
    n_points: int = N_POINTS


def fields_for(per_pass: float, fixed: int | None = None) -> int:
    """Joint draws of the emulator to average over when one pass of Eq. (21) over the
    :data:`N_POINTS` points takes ``per_pass`` CPU seconds (:data:`BUDGET_S`, at least
    :data:`MIN_FIELDS`, at most :data:`N_FIELDS`), or ``fixed`` draws when it is given (the
    method's ``error_draws``: the same number on any machine, so the same draws for a seed)."""
    if fixed is not None:
        return int(fixed)
    return int(min(N_FIELDS, max(MIN_FIELDS, BUDGET_S // max(per_pass, 1e-9))))


def error_fields(log_joint: EmulatedLogJoint, rows: np.ndarray, n_fields: int,
                 rng: np.random.Generator) -> np.ndarray:
    """`n_fields x S` log joints at rows `S x D` of joint draws of the emulator (-inf outside
    the support).

    A draw is the emulator's mean plus an error field ``δ_j(θ) = sqrt(v_j(θ)) (B z(θ))_j`` at
    every reading `j`: ``B`` the runs' field shapes (:attr:`FieldEmulator.error_basis`, `m x
    N`, unit rows), ``z`` `N` independent draws of the emulator's standardised latent GP,
    jointly over the `S` rows (its posterior correlation between them), ``v`` the calibrated
    variance. Eq. (21) is evaluated at each drawn field exactly, so a large error costs what
    its misfit costs (a first-order error would let any region far from the data gain
    without bound).
    """
    value = np.asarray(log_joint.problem.log_prior(rows), dtype=np.float64).reshape(-1)
    out = np.repeat(value[None, :], int(n_fields), axis=0)
    theta = torch.as_tensor(np.atleast_2d(rows), dtype=torch.float64)
    emulator = log_joint.emulator
    corr = emulator.latent_correlation(log_joint.problem.split.physical(theta))
    eye = torch.eye(corr.shape[0], dtype=corr.dtype)
    for jitter in (1e-10, 1e-8, 1e-6, 1e-4):
        factor, info = torch.linalg.cholesky_ex(corr + jitter * eye)
        if int(info) == 0:
            break
    else:  # a spectral square root
        values, vectors = torch.linalg.eigh(corr)
        factor = vectors * values.clamp_min(0.0).sqrt()
    n_latent = emulator.error_basis.shape[1]  # N
    z = torch.stack([factor @ torch.as_tensor(rng.standard_normal((corr.shape[0], n_latent)),
                                              dtype=corr.dtype) for _ in range(int(n_fields))])
    # the emulator's mean and variance a chunk of rows at a time: `CHUNK x m` in memory, not
    # `S x m` (a camera field has 10^5 readings or more)
    for part in torch.arange(theta.shape[0]).split(CHUNK):
        mean, var, rows_part = log_joint.parts(theta[part].numpy())  # var: calibrated
        for k in range(int(n_fields)):
            out[k, part.numpy()] += log_joint.at_error(mean, var, rows_part, z[k, part])
    out[~np.isfinite(out)] = -np.inf
    return out


def evidence_spread(log_joint: EmulatedLogJoint, draws: np.ndarray, n_fields: int,
                    rng: np.random.Generator) -> float:
    """The sd [nats] of the log evidence over joint draws of the emulator's error, from draws
    `S x D` of its plug-in posterior: for each of ``n_fields`` draws ``f``,
    ``log Z_f - log Z = log E_post[exp(ℓ_f(θ) - ℓ(θ))]`` (:func:`error_fields`' error model),
    and their sd (inf when fewer than 10 draws have finite values).

    It is what the emulator's error does to the evidence. The first-order sd at each draw,
    averaged over them (:meth:`EmulatedLogJoint.emulator_share`), bounds it from above: errors
    that move the log-likelihood alike at every draw move log Z by as much, but errors that
    differ across the posterior average out, and the first-order form takes the readings'
    errors as independent. On ``fifth3_p6`` (eight parameters) the two were 0.63 and 0.04
    nats at 120 runs, and 0.30 and 0.017 at 260.
    """
    plug_in = np.asarray(log_joint(draws), dtype=np.float64)
    delta = error_fields(log_joint, draws, n_fields, rng) - plug_in[None, :]
    ok = np.isfinite(delta).all(0)
    if ok.sum() < 10:
        return float("inf")
    log_ratio = logsumexp(delta[:, ok], axis=1) - np.log(ok.sum())
    return float(np.std(log_ratio, ddof=1))


def average_over_errors(log_joint: EmulatedLogJoint, draws: np.ndarray, hard: np.ndarray,
                        plausible: np.ndarray, n: int, seed: int,
                        n_fields: int | None = None) -> Averaged | None:
    """The posterior of ``log_joint`` averaged over draws of its error (module docstring).

    Args:
        log_joint: the last round's emulated log joint.
        draws: `S x D` draws of its plug-in posterior.
        hard, plausible: `D x 2` search and plausible bounds.
        n: draws to return.
        seed: seed of the proposal, the error draws and the resampling.
        n_fields: joint draws of the emulator to average over (None: as many as
            :data:`BUDGET_S` allows, :func:`fields_for`).

    Returns:
        The averaged posterior, or None when no proposal point has a finite log joint. Made
        on :data:`N_POINTS` points, and again on more when that keeps fewer than
        :data:`MIN_ESS` effective draws (many parameters: the proposal's volume grows
        faster than the posterior's).
    """
    rng = np.random.default_rng([seed, 41])
    mix = fit_mixture(draws, sampling.transformer(hard, plausible), seed)
    proposal = mix.defensive(plausible, WIDEN, DEFENSIVE, SLABS)
    out = _average(log_joint, proposal, N_POINTS, n, rng, n_fields)
    if out is None or out.ess >= MIN_ESS:
        return out
    size = min(MAX_POINTS, int(np.ceil(N_POINTS * TARGET_ESS / max(out.ess, 1.0))))
    return _average(log_joint, proposal, size, n, rng, n_fields)  # the ESS grows with the points


def _average(log_joint: EmulatedLogJoint, proposal: Mixture, size: int, n: int,
             rng: np.random.Generator, fixed: int | None = None) -> Averaged | None:
    """:func:`average_over_errors` on ``size`` points of ``proposal`` (a :class:`.Mixture`)."""
    points = proposal.sample(size, rng)
    log_q = np.asarray(proposal.log_pdf(points), dtype=np.float64)
    ok = np.isfinite(np.asarray(log_joint.problem.log_prior(points), dtype=np.float64)
                     ).reshape(-1) & np.isfinite(log_q)
    if not ok.any():
        return None
    points, log_q = points[ok], log_q[ok]
    start = time.process_time()
    plug_in = np.asarray(log_joint(points), dtype=np.float64)
    per_pass = max(time.process_time() - start, 1e-6)
    n_fields = fields_for(per_pass, fixed)
    fields = error_fields(log_joint, points, n_fields, rng)  # K x S log joints
    log_w = fields - log_q[None, :]
    log_z = logsumexp(log_w, axis=1) - np.log(points.shape[0])  # K
    weights = np.exp(log_w - logsumexp(log_w, axis=1, keepdims=True)).mean(0)
    weights /= weights.sum()
    ess = float(1.0 / np.square(weights).sum())
    spread = np.where(np.isfinite(fields), fields - plug_in[None, :], np.nan)
    sd = np.nanstd(spread, axis=0)
    heavy = weights >= np.quantile(weights, 0.5)
    return Averaged(points[sampling.resample(weights, n, rng)], ess, float(np.std(log_z)),
                    float(np.nanmedian(sd[heavy])), n_fields, int(points.shape[0]))


__all__ = ["Averaged", "EVIDENCE_DRAWS", "EVIDENCE_FIELDS", "EVIDENCE_UPPER", "MAX_POINTS", "MIN_ESS", "N_FIELDS", "N_POINTS", "TARGET_ESS",
           "average_over_errors", "error_fields", "evidence_spread", "fields_for"]

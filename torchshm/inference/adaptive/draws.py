"""The returned draws and evidence of the emulator method: importance sampling of the emulated
posterior (:func:`posterior_draws`), in more passes where the first leaves a moment uncertain.

The proposal is a full-covariance mixture fitted to the last chain (:mod:`.mixture`), widened,
with slabs that carry each coordinate over the plausible box. Its effective sample size can be
in the thousands while a parameter's sd still rests on a few dozen heavy draws: a saturating
spring whose posterior has a long tail towards a plateau holds about 1 % of its mass there,
reached mostly by the slabs, and that 1 % sets a fifth of its variance. On the held-out
``sixth6_p4`` (2026-11-30) twelve passes of 8,000 draws on the same emulator gave that spring's
sd from 0.24 to 0.32 (a long emcee chain on the model: 0.255). So the Monte Carlo error of every
parameter's mean and sd is estimated from the weights (delta method, :func:`moment_errors`);
while one exceeds :data:`MOMENT_TOL` another pass is drawn from a mixture fitted to the draws
so far (which now holds the tail the weights found), up to :data:`MAX_PASSES` more, and all
passes are pooled with the balance heuristic (each draw weighted against the passes' mixture
of proposals; Veach & Guibas 1995). On that case the pooled sd over ten seeds spread by 0.008
against 0.012 for one pass of as many draws.
"""

from __future__ import annotations

import warnings
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.special import logsumexp

from torchshm.inference.adaptive import sampling
from torchshm.inference.adaptive.mixture import Mixture, fit_mixture

if TYPE_CHECKING:
    from pyvbmc import VariationalPosterior
    from pyvbmc.parameter_transformer import ParameterTransformer

    from torchshm.inference.adaptive.likelihood import EmulatedLogJoint

#: importance sampling is tried again (the mixture widened more, or fitted to the first
#: draws: :func:`posterior_draws`) when its effective sample size is below this share of them
REFIT_SHARE = 0.25
#: fewest effective importance samples from which the draws are resampled; below it the
#: returned draws are the chain's (thinned) and the evidence is flagged
MIN_ESS = 200.0
#: fewest effective importance samples whose resampled draws a mixture is fitted to again
MIN_REFIT_ESS = 50.0
#: widening of the defensive part of the second proposal (the first: 2)
WIDE = 3.0
#: a second try is judged on a pilot of ``n // PILOT_SHARE`` draws (at least ``PILOT_MIN``)
PILOT_SHARE, PILOT_MIN = 8, 500
#: share of the proposal in the mixture widened, and in its slabs (:meth:`.Mixture.with_slabs`)
DEFENSIVE, SLABS = 0.25, 0.2
#: largest Monte Carlo sd of a parameter's posterior mean (in its posterior sds) and relative
#: Monte Carlo sd of its posterior sd that the draws may keep before another pass is drawn
MOMENT_TOL = 0.03
#: most passes drawn after the first for :data:`MOMENT_TOL`
MAX_PASSES = 2
#: a Monte Carlo error of a moment above this after the passes is a warning
MOMENT_WARN = 0.1


def moment_errors(draws: np.ndarray, log_w: np.ndarray) -> np.ndarray:
    """`D` Monte Carlo sd of each coordinate's self-normalised importance estimates, to first
    order (delta method): the larger of its mean's (in its sds) and its sd's (relative).

    Args:
        draws: `M x D` proposal draws; log_w: `M` their log weights (not finite: weight 0).
    """
    log_w = np.where(np.isfinite(log_w), log_w, -np.inf)
    w = np.exp(log_w - log_w.max())
    w = w / w.sum()
    dev = draws - w @ draws
    var = np.maximum(w @ np.square(dev), 1e-300)
    mean_err = np.sqrt(np.square(w) @ np.square(dev) / var)
    sd_err = 0.5 * np.sqrt(np.square(w) @ np.square(np.square(dev) - var)) / var
    return np.maximum(mean_err, sd_err)


def pooled_passes(log_joint: EmulatedLogJoint, first: Mixture, draws: np.ndarray,
                  log_p: np.ndarray, n: int, seed: int, tr: ParameterTransformer,
                  plausible: np.ndarray) -> tuple[sampling.Importance, int, float]:
    """Importance draws from ``first`` (`n x D` ``draws``, emulated log joint ``log_p``) and,
    while :func:`moment_errors` exceeds :data:`MOMENT_TOL`, up to :data:`MAX_PASSES` passes of
    ``n`` more from a mixture fitted to the pooled draws resampled, with slabs as the first.

    Returns:
        The pooled :class:`.sampling.Importance` (``n`` draws resampled; log evidence over all
        passes), the number of passes after the first and the largest moment error.
    """
    passes, xs, lps = [first], [draws], [log_p]
    rng = np.random.default_rng([seed, 23])
    while True:
        x, lp = np.concatenate(xs), np.concatenate(lps)
        counts = np.log([len(v) for v in xs])
        log_q = logsumexp(np.stack([c + np.asarray(q.log_pdf(x)).reshape(-1)
                                    for c, q in zip(counts, passes)]), axis=0) - logsumexp(counts)
        log_w = lp - log_q
        error = float(np.max(moment_errors(x, log_w)))
        if error <= MOMENT_TOL or len(passes) > MAX_PASSES or not np.isfinite(error):
            break
        finite = np.where(np.isfinite(log_w), log_w, -np.inf)
        w = np.exp(finite - finite.max())
        refit = fit_mixture(x[sampling.resample(w, n, rng)], tr, seed + 31 + len(passes))
        passes.append(refit.defensive(plausible, 2.0, DEFENSIVE, SLABS))
        xs.append(passes[-1].sample(n, rng))
        lps.append(np.asarray(log_joint(xs[-1]), dtype=np.float64).reshape(-1))
    return sampling.weigh(x, log_w, n, rng), len(passes) - 1, error


def posterior_draws(log_joint: EmulatedLogJoint, chain: np.ndarray, hard: np.ndarray,
                    plausible: np.ndarray, n: int, seed: int,
                    ) -> tuple[sampling.Importance, VariationalPosterior, str, dict[str, Any]]:
    """Evidence, draws and stored density of the emulated posterior from its chain `S x D`.

    Importance sampling from the full-covariance mixture of the chain (:mod:`.mixture`),
    widened, and with slabs that carry each coordinate over the plausible box
    (:meth:`.Mixture.with_slabs`); when its effective sample size is below
    :data:`REFIT_SHARE` of ``n``,
    again from the same mixture widened more (:data:`WIDE`: tails heavier than the mixture's,
    e.g. mass piled against a bound, which the unbounded coordinates stretch into a long tail)
    and from a mixture fitted to the first draws (which the weights moved to where the
    posterior's mass is: a mode the chain under-filled), each judged on a pilot of
    ``n //`` :data:`PILOT_SHARE` draws, the better one made in full if its pilot's effective
    share beats the first's, keeping the larger effective sample (so at most about 1.25
    passes more than the first instead of 2). Then up to :data:`MAX_PASSES` more passes,
    pooled, while a parameter's mean or sd is uncertain (:func:`pooled_passes`).
    Below :data:`MIN_ESS` the draws are the chain's, thinned to ``n``, and a warning says so.

    Returns:
        ``(result, vp, source, info)``: the kept :class:`.sampling.Importance` (log evidence
        [nats], its Monte Carlo sd, effective sample size, Pareto k-hat and `n x D` draws, the
        chain's when ``source`` is ``"chain"``), the PyVBMC density fitted to the draws (in the
        coordinates of one mode's shape: :meth:`.mixture.Mixture.pooled_covariance`),
        ``"importance"`` or ``"chain"``, and ``{"importance_passes": k, "draws_moment_error":
        e}`` (the passes after the first and the largest Monte Carlo error of a mean or sd,
        :func:`moment_errors`; 0 and NaN for the chain's draws).
    """
    tr = sampling.transformer(hard, plausible)
    mix = fit_mixture(chain, tr, seed)

    def proposal(fitted: Mixture, factor: float) -> Mixture:
        return fitted.defensive(plausible, factor, DEFENSIVE, SLABS)

    q = proposal(mix, 2.0)
    best, draws, log_p = sampling.importance_pass(log_joint, q, n, seed)
    if best.ess < REFIT_SHARE * n:  # tails heavier than the defensive part's, or a mode missed
        tries = [(mix, WIDE)]
        if best.ess >= MIN_REFIT_ESS:
            tries.append((fit_mixture(best.draws, tr, seed + 1), 2.0))
        # a pilot of each try, and a full pass for the best one only if it promises more
        m = min(n, max(PILOT_MIN, n // PILOT_SHARE))
        share = [sampling.importance(log_joint, proposal(*t), m, seed + 1 + i).ess / m
                 for i, t in enumerate(tries)]
        i = int(np.argmax(share))
        if share[i] > best.ess / n:
            tried = proposal(*tries[i])
            other = sampling.importance_pass(log_joint, tried, n, seed + 11 + i)
            if other[0].ess > best.ess:
                (best, draws, log_p), mix, q = other, tries[i][0], tried
    source, info = "importance", {"importance_passes": 0, "draws_moment_error": np.nan}
    if best.ess >= MIN_ESS:  # more passes while a mean or sd rests on a few heavy draws
        pooled, k, error = pooled_passes(log_joint, q, draws, log_p, n, seed, tr, plausible)
        best = pooled if k else best
        info = {"importance_passes": k, "draws_moment_error": error}
        if error > MOMENT_WARN:
            warnings.warn(
                f"method='emulator': after {k + 1} passes of importance sampling a posterior mean "
                f"or sd of the returned draws still has a Monte Carlo error of {error:.2g} (of an "
                "sd): raise n_evidence", RuntimeWarning, stacklevel=4)
    if best.ess < MIN_ESS:
        source = "chain"
        best = best._replace(draws=chain[np.linspace(0, chain.shape[0] - 1,
                                                     min(n, chain.shape[0])).astype(int)])
        warnings.warn(
            f"method='emulator': importance sampling of the emulated posterior kept {best.ess:.0f} "
            f"effective draws of {n} (fewer than {MIN_ESS:.0f}); the posterior draws are the "
            "chain's (their shares of several modes are the chain's) and the log evidence is "
            "unreliable: raise final_steps and n_evidence",
            RuntimeWarning, stacklevel=4)
    vp = sampling.fit_density(best.draws, hard, plausible, seed,
                              covariance=mix.pooled_covariance())
    return best, vp, source, info


__all__ = ["DEFENSIVE", "MAX_PASSES", "MIN_ESS", "MOMENT_TOL", "SLABS", "moment_errors",
           "pooled_passes", "posterior_draws"]

"""Posterior, density and evidence on the emulated log joint (no model runs).

Each round samples the emulated log joint with emcee (vectorised; walkers start where the
previous round's ended). The final step (:mod:`.final`) draws the posterior by importance
sampling from a full-covariance Gaussian mixture fitted to the chain and widened for heavier
tails (:mod:`.mixture`; a defensive proposal): the log evidence with its Monte Carlo standard
deviation, and the returned draws (resampled by weight: nearly independent, so far less Monte
Carlo error than the correlated chain). A PyVBMC ``VariationalPosterior`` fitted to those
draws is the stored density, so that ``log_pdf``, ``kl_divergence`` and saving work as for
VBMC.
"""

from __future__ import annotations

import warnings
from typing import Callable, NamedTuple, Protocol

import emcee
import numpy as np
from pyvbmc import VariationalPosterior
from pyvbmc.parameter_transformer import ParameterTransformer
from scipy.special import logsumexp
from scipy.stats import chi2

from torchshm.inference.adaptive.mixture import best_by_bic

LogDensity = Callable[[np.ndarray], np.ndarray]


class Proposal(Protocol):
    """An importance proposal: draws and their log density in the original coordinates."""

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray: ...

    def log_pdf(self, theta: np.ndarray) -> np.ndarray: ...


def run_chain(log_joint: LogDensity, start: np.ndarray, n_steps: int, seed: int,
              hop: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """emcee from walkers ``start`` `W x D` for ``n_steps``; the second half is kept.

    With ``hop`` (walkers in several modes, :mod:`.modes`) a fifth of the moves are
    differential-evolution jumps by the whole difference of two walkers (``gamma = 1``), which
    carry walkers between modes so that the chain sets the modes' shares.

    Stragglers (walkers far below the others in log density, see :func:`straggler_gap`) are
    moved onto good walkers before the chain, and the samples of a walker that still lags in
    the kept half are left out: a walker stranded where the emulator extrapolates would
    otherwise stay there, and the batch rule would spend runs chasing it.

    Returns:
        ``(samples, last)``: `S x D` samples (step-major) and the final walkers `W x D`.
    """
    n_walkers, dim = start.shape
    start = regroup(log_joint, start, seed)
    moves = [(emcee.moves.StretchMove(), 0.8), (emcee.moves.DEMove(gamma0=1.0), 0.2)] if hop \
        else None
    sampler = emcee.EnsembleSampler(n_walkers, dim, log_joint, vectorize=True, moves=moves)
    state = emcee.State(start, random_state=np.random.RandomState(seed).get_state())
    sampler.run_mcmc(state, int(n_steps), progress=False)
    chain = sampler.get_chain()[int(n_steps) // 2:]
    level = np.median(sampler.get_log_prob()[int(n_steps) // 2:], axis=0)  # per walker
    keep = level >= np.max(level) - straggler_gap(dim)
    if not keep.any():
        keep[:] = True
    return chain[:, keep].reshape(-1, dim), sampler.get_chain()[-1]


def straggler_gap(dim: int) -> float:
    """How far [nats] below the best walker a walker counts as stranded: half the
    1 - 1e-6 quantile of chi-square with ``dim`` degrees of freedom (a Gaussian posterior puts
    a draw that far below its mode once in a million)."""
    return 0.5 * float(chi2.ppf(1 - 1e-6, dim))


def regroup(log_joint: LogDensity, walkers: np.ndarray, seed: int) -> np.ndarray:
    """``walkers`` `W x D` with each straggler replaced by a good walker, jittered by 1e-3 of
    the good walkers' spread (the same array when there is none)."""
    lp = np.asarray(log_joint(walkers), dtype=np.float64)
    finite = np.isfinite(lp)
    if not finite.any():
        return walkers
    bad = ~finite | (lp < lp[finite].max() - straggler_gap(walkers.shape[1]))
    good = np.flatnonzero(~bad)
    if not bad.any():
        return walkers
    rng = np.random.default_rng([seed, 31])
    spread = (walkers[good] if good.size > 1 else walkers).std(axis=0) + 1e-12
    out = walkers.copy()
    out[bad] = walkers[rng.choice(good, int(bad.sum()))] + 1e-3 * spread * rng.standard_normal(
        (int(bad.sum()), walkers.shape[1]))
    return out


def walkers_from(samples: np.ndarray, n_walkers: int, rng: np.random.Generator) -> np.ndarray:
    """``n_walkers`` distinct rows drawn from ``samples`` (the next round's starting walkers)."""
    index = rng.choice(samples.shape[0], size=n_walkers, replace=samples.shape[0] < n_walkers)
    return samples[index].copy()


def transformer(hard: np.ndarray, plausible: np.ndarray, covariance: np.ndarray | None = None,
                ) -> ParameterTransformer:
    """PyVBMC's transform of the bounded parameters to unbounded ones (as VBMC builds it);
    with ``covariance`` `D x D` (of the unbounded coordinates), followed by PyVBMC's
    "rotoscaling" to the coordinates in which that covariance is the identity."""
    lb, ub, plb, pub = (v.reshape(1, -1).copy() for v in (*hard.T, *plausible.T))
    rotation = scale = None
    if covariance is not None:
        values, rotation = np.linalg.eigh(np.asarray(covariance, dtype=np.float64))
        scale = np.sqrt(np.maximum(values, 1e-12 * max(float(values.max()), 1e-300)))
    return ParameterTransformer(hard.shape[0], lb, ub, plb, pub, transform_type="probit",
                                rotation_matrix=rotation, scale=scale)


def fit_density(samples: np.ndarray, hard: np.ndarray, plausible: np.ndarray, seed: int,
                max_components: int = 8, covariance: np.ndarray | None = None,
                ) -> VariationalPosterior:
    """A PyVBMC ``VariationalPosterior`` (Gaussian mixture) fitted to ``samples`` `S x D`.

    The mixture lives in PyVBMC's unbounded coordinates; its components share a scale per
    coordinate (``lambd``) and have one width each (``sigma``), PyVBMC's parametrisation, so
    it cannot give each component its own shape. With ``covariance`` `D x D` of one mode in
    the unbounded coordinates (e.g. :meth:`.mixture.Mixture.pooled_covariance`), the
    coordinates are first rotated and scaled so that it is the identity (PyVBMC's
    rotoscaling, kept in the transform): a correlated mode, or several modes of one shape far
    apart, are then each covered by a few round components. Without it the scale is the
    samples' sd per coordinate. The number of components is chosen by BIC up to
    ``max_components``.
    """
    tr = transformer(hard, plausible, covariance)
    z = tr(samples)
    lambd = (z.std(axis=0) if covariance is None else np.ones(z.shape[1])) + 1e-12
    u = (z - z.mean(axis=0)) / lambd
    best = best_by_bic(u, "spherical", seed, max_components, max_iter=100)
    k = best.n_components
    vp = VariationalPosterior(D=z.shape[1], K=k, parameter_transformer=tr,
                              rng=np.random.default_rng([seed, 17]))
    vp.w = best.weights_.reshape(1, -1).copy()
    vp.eta = np.log(vp.w)
    vp.mu = (best.means_ * lambd + z.mean(axis=0)).T.copy()
    vp.sigma = np.sqrt(best.covariances_).reshape(1, -1).copy()
    vp.lambd = lambd.reshape(-1, 1).copy()
    return vp


class Importance(NamedTuple):
    """Result of :func:`importance`."""

    #: log evidence [nats]
    log_z: float
    #: its Monte Carlo standard deviation (delta method) [nats]
    sd: float
    #: effective sample size of the weights
    ess: float
    #: `n x D` draws resampled by weight
    draws: np.ndarray
    #: Pareto shape of the largest weights' tail (Vehtari et al., PSIS): above 0.7 the
    #: estimates are unreliable whatever the effective sample size says
    khat: float


def importance(log_joint: LogDensity, proposal: Proposal, n: int, seed: int) -> Importance:
    """Log evidence [nats] and posterior draws by importance sampling from ``proposal``.

    Args:
        log_joint: vectorised unnormalised log posterior of rows `B x D`.
        proposal: a density with ``sample(n, rng)`` and ``log_pdf(theta)`` (e.g. a
            :class:`.mixture.Mixture`, widened for heavier tails).
        n: number of importance samples.
        seed: seed of the draws and of the resampling.

    Returns:
        The log evidence, its Monte Carlo sd, the effective sample size, `n x D` draws
        resampled by weight (systematic resampling, distributed as the posterior up to the
        proposal's Monte Carlo error) and the Pareto diagnostic of the weights (ArviZ's
        ``psislw``).
    """
    return importance_pass(log_joint, proposal, n, seed)[0]


def importance_pass(log_joint: LogDensity, proposal: Proposal, n: int,
                    seed: int) -> tuple[Importance, np.ndarray, np.ndarray]:
    """:func:`importance` (the same draws), with the proposal's draws `n x D` and the log
    joint `n` there (for pooling with further passes)."""
    rng = np.random.default_rng([seed, 19])
    draws = proposal.sample(int(n), rng)
    log_p = np.asarray(log_joint(draws), dtype=np.float64).reshape(-1)
    log_q = np.asarray(proposal.log_pdf(draws), dtype=np.float64).reshape(-1)
    return weigh(draws, log_p - log_q, int(n), rng), draws, log_p


def weigh(draws: np.ndarray, log_w: np.ndarray, n: int, rng: np.random.Generator) -> Importance:
    """The :class:`Importance` of proposal draws `M x D` with log weights ``log_w`` `M`
    (target minus proposal log density; not finite: weight 0), and ``n`` draws resampled."""
    log_w = np.where(np.isfinite(log_w), log_w, -np.inf)
    m = draws.shape[0]
    log_z = float(logsumexp(log_w) - np.log(m))
    w = np.exp(log_w - log_w.max())
    ess = float(w.sum() ** 2 / np.square(w).sum())
    rel = float(np.std(w / w.mean(), ddof=1) / np.sqrt(m))
    return Importance(log_z, rel, ess, draws[resample(w, n, rng)], pareto_k(log_w))


def resample(weights: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """`n` indices into ``weights`` `S` (unnormalised, >= 0) by systematic resampling, in a
    random order."""
    positions = (rng.random() + np.arange(n)) / n
    index = np.minimum(np.searchsorted(np.cumsum(weights) / weights.sum(), positions),
                       weights.shape[0] - 1)
    return rng.permutation(index)


def pareto_k(log_w: np.ndarray) -> float:
    """Pareto shape `k` of the upper tail of the log weights ``log_w`` `n` (ArviZ's PSIS fit;
    ``inf`` when no weight is finite)."""
    finite = log_w[np.isfinite(log_w)]
    if finite.size < 10:
        return float("inf")
    import arviz as az  # with xarray and pandas: loaded when first needed

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # ArviZ warns above 0.7: the caller decides
        _, khat = az.psislw(finite - finite.max())
    return float(khat)


def total_variation(log_new: np.ndarray, log_old: np.ndarray) -> float:
    """Total variation between two posteriors from draws of the new one.

    With ``log_new`` and ``log_old`` the two unnormalised log densities at the same `S` draws
    of the new posterior, ``TV = ½ E_new |1 - p_old / p_new|``, the ratio of normalisers
    estimated by the mean weight. This bounds the largest marginal TV (MMTV) from above and
    has little Monte Carlo noise when the two posteriors are close.
    """
    log_w = np.where(np.isfinite(log_old), log_old - log_new, -np.inf)
    if not np.isfinite(log_w).any():
        return 1.0
    w = np.exp(log_w - np.max(log_w))
    return float(min(1.0, 0.5 * np.mean(np.abs(1.0 - w / w.mean()))))


def marginal_tv(a: np.ndarray, b: np.ndarray, bins: int = 40) -> float:
    """Largest marginal total variation (MMTV) between sample sets `S x D` and `T x D`."""
    worst = 0.0
    for d in range(a.shape[1]):
        lo, hi = np.quantile(np.concatenate([a[:, d], b[:, d]]), [0.001, 0.999])
        edges = np.linspace(lo, hi + 1e-12, bins + 1)
        pa = np.histogram(np.clip(a[:, d], lo, hi), edges)[0] / a.shape[0]
        pb = np.histogram(np.clip(b[:, d], lo, hi), edges)[0] / b.shape[0]
        worst = max(worst, 0.5 * float(np.abs(pa - pb).sum()))
    return worst

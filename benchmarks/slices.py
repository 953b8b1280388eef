"""A reference that integrates a long flat tail: 1-D quadrature over one parameter of its
conditional evidence, each slice by importance sampling.

For a parameter ``k`` (column ``axis``) whose posterior has a peak and a long low plateau (a
spring that stops mattering below some stiffness), a chain started at the peak rarely visits
the plateau and under-weights it. Here the posterior is integrated slice by slice instead:

1. :func:`conditional_slices`: at each grid value ``g`` of ``k``, the conditional mode of the
   other parameters (Nelder-Mead from the neighbouring slice's mode and from a fixed start),
   a Laplace covariance (finite-difference Hessian), then two stages of importance sampling
   from Student-t's (the second centred on the first stage's weighted moments and mixed with a
   widened Laplace t, a defensive proposal) give ``log Z(g) = log ∫ p(y, θ_-k, g) dθ_-k``, its
   Monte Carlo sd, the ESS and the conditional means and variances;
2. :func:`integrate`: the marginal of ``k`` is ``Z(g)`` (the prior of ``k`` is in the log
   joint), integrated by the trapezoid rule on the grid; moments of every parameter follow
   from the conditional moments. Two error figures: the grid error (the same on every other
   node) and the Monte Carlo error (the per-slice ``log Z`` perturbed by their sds).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from scipy import optimize, stats
from scipy.special import logsumexp

LogDensity = Callable[[np.ndarray], np.ndarray]


def conditional_slices(log_joint: LogDensity, axis: int, grid: np.ndarray, start: np.ndarray,
                       scale: np.ndarray, n: int = 3000, seed: int = 0, df: float = 4.0) -> dict[str, np.ndarray]:
    """Conditional evidence and moments at every value of ``grid`` (`G`) of parameter ``axis``.

    Args:
        log_joint: log joint of rows `B x D` (-inf outside the support).
        start: `D` a point near the peak (its ``axis`` entry is ignored).
        scale: `D` widths to optimise in (the plausible box).
        n: importance draws of the second stage (the first has ``n // 3``).

    Returns:
        ``log_z``, ``log_z_sd``, ``ess`` (`G`), ``mean``, ``var`` (`G x D`: conditional moments,
        the ``axis`` column the grid value and 0), ``mode`` (`G x D`).
    """
    rest = [j for j in range(start.size) if j != axis]
    rng = np.random.default_rng([seed, 41])
    out: dict[str, list] = {k: [] for k in ("log_z", "log_z_sd", "ess", "mean", "var", "mode")}
    previous = start[rest]
    for g in grid:
        def full(z: np.ndarray, g: float = g) -> np.ndarray:
            z = np.atleast_2d(z)
            rows = np.empty((z.shape[0], start.size))
            rows[:, rest], rows[:, axis] = z, g
            return rows

        mode = _mode(lambda z: log_joint(full(z)), [previous, start[rest]], scale[rest])
        cov = _laplace(lambda z: log_joint(full(z)), mode, scale[rest])
        t1 = stats.multivariate_t(mode, 1.5**2 * cov, df=df, seed=rng)
        x1 = t1.rvs(n // 3).reshape(-1, len(rest))
        w1 = _weights(log_joint(full(x1)) - t1.logpdf(x1))
        m1 = w1 @ x1
        c1 = (x1 - m1).T @ ((x1 - m1) * w1[:, None]) + 1e-12 * np.diag(scale[rest] ** 2)
        comps = [stats.multivariate_t(m1, 1.2**2 * c1, df=df, seed=rng),
                 stats.multivariate_t(mode, 2.0**2 * cov, df=df, seed=rng)]
        share = np.array([0.7, 0.3])
        counts = rng.multinomial(n, share)
        x = np.vstack([c.rvs(m).reshape(m, -1) for c, m in zip(comps, counts)])
        log_q = logsumexp(np.stack([c.logpdf(x) for c in comps], 1) + np.log(share), axis=1)
        log_w = log_joint(full(x)) - log_q
        log_w = np.where(np.isfinite(log_w), log_w, -np.inf)
        w = np.exp(log_w - log_w.max())
        wn = w / w.sum()
        mean, var = np.zeros(start.size), np.zeros(start.size)
        mean[rest], mean[axis] = wn @ x, g
        var[rest] = wn @ np.square(x - mean[rest])
        out["log_z"].append(float(log_w.max() + np.log(w.mean())))
        out["log_z_sd"].append(float(np.std(w, ddof=1) / np.sqrt(n) / w.mean()))
        out["ess"].append(float(1.0 / np.square(wn).sum()))
        out["mean"].append(mean)
        out["var"].append(var)
        out["mode"].append(full(mode)[0])
        previous = mode
    return {k: np.asarray(v) for k, v in out.items()}


def conditional_optima(log_joint: LogDensity, axis: int, value: float, starts: np.ndarray,
                       scale: np.ndarray) -> list[float]:
    """Maximum log joint with parameter ``axis`` at ``value`` from each of ``starts`` `S x D`
    (one optimisation each): equal values say the conditional has one mode."""
    rest = [j for j in range(starts.shape[1]) if j != axis]

    def f(z: np.ndarray) -> np.ndarray:
        rows = np.full((np.atleast_2d(z).shape[0], starts.shape[1]), value)
        rows[:, rest] = np.atleast_2d(z)
        return log_joint(rows)

    return [float(f(_mode(f, [s[rest]], scale[rest]))[0]) for s in starts]


def _mode(f: Callable[[np.ndarray], np.ndarray], starts: list[np.ndarray], scale: np.ndarray) -> np.ndarray:
    """The best of Nelder-Mead maximisations of ``f`` from ``starts`` (in units of ``scale``)."""
    def loss(u: np.ndarray) -> float:
        v = float(f(u * scale)[0])
        return -v if np.isfinite(v) else 1e12

    best = None
    for s in starts:
        r = optimize.minimize(loss, s / scale, method="Nelder-Mead",
                              options={"maxfev": 2000, "xatol": 1e-6, "fatol": 1e-7, "adaptive": True})
        if best is None or r.fun < best.fun:
            best = r
    assert best is not None
    return best.x * scale


def _laplace(f: Callable[[np.ndarray], np.ndarray], mode: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """Inverse of minus the finite-difference Hessian of ``f`` at ``mode`` (a diagonal of
    ``(scale / 10)²`` where that is not positive definite)."""
    d = mode.size
    h = 1e-3 * scale
    steps = [np.zeros(d)]
    for i in range(d):
        for j in range(i, d):
            for si, sj in ((1, 1), (1, -1), (-1, 1), (-1, -1)):
                e = np.zeros(d)
                e[i] += si * h[i]
                e[j] += sj * h[j]
                steps.append(e)
    values = f(mode + np.asarray(steps))
    hess, k = np.zeros((d, d)), 1
    for i in range(d):
        for j in range(i, d):
            pp, pm, mp, mm = values[k:k + 4]
            hess[i, j] = hess[j, i] = (pp - pm - mp + mm) / (4 * h[i] * h[j])
            k += 4
    try:
        cov = np.linalg.inv(-hess)
        np.linalg.cholesky(cov)
        return cov
    except np.linalg.LinAlgError:
        return np.diag((scale / 10.0) ** 2)


def _weights(log_w: np.ndarray) -> np.ndarray:
    """Normalised importance weights of ``log_w`` (-inf and nan weigh 0)."""
    log_w = np.where(np.isfinite(log_w), log_w, -np.inf)
    w = np.exp(log_w - log_w.max())
    return w / w.sum()


def integrate(grid: np.ndarray, slices: dict[str, np.ndarray], axis: int, tail_below: tuple[float, ...],
              n_perturb: int = 400, seed: int = 0) -> dict[str, Any]:
    """Marginal mean and sd of every parameter and the masses with ``k <= t`` for each ``t`` of
    ``tail_below`` (grid values, on every other node too).

    Returns:
        ``mean``, ``sd`` (`D`), ``tail_mass`` (one per threshold), each with ``*_grid_error`` (the trapezoid on
        every other node minus on all) and ``*_mc_sd`` (sd over ``log Z`` perturbed by its
        Monte Carlo sd), and the marginal density of ``k`` on the grid (``density``).
    """
    best = _moments(grid, slices["log_z"], slices["mean"], slices["var"], axis, tail_below)
    coarse = _moments(grid[::2], slices["log_z"][::2], slices["mean"][::2], slices["var"][::2], axis,
                      tail_below)
    rng = np.random.default_rng([seed, 43])
    runs = [_moments(grid, slices["log_z"] + slices["log_z_sd"] * rng.standard_normal(grid.size),
                     slices["mean"], slices["var"], axis, tail_below) for _ in range(n_perturb)]
    out: dict[str, Any] = {}
    for key in ("mean", "sd", "tail_mass"):
        out[key] = best[key]
        out[f"{key}_grid_error"] = np.asarray(coarse[key]) - np.asarray(best[key])
        out[f"{key}_mc_sd"] = np.std([r[key] for r in runs], axis=0)
    out["density"] = best["density"]
    return out


def _moments(grid: np.ndarray, log_z: np.ndarray, mean: np.ndarray, var: np.ndarray, axis: int,
             tail_below: tuple[float, ...]) -> dict[str, Any]:
    """Trapezoid-rule moments from the slices (see :func:`integrate`)."""
    z = np.exp(log_z - log_z.max())
    total = np.trapezoid(z, grid)
    m1 = np.trapezoid(z[:, None] * mean, grid, axis=0) / total
    m2 = np.trapezoid(z[:, None] * (var + np.square(mean)), grid, axis=0) / total
    tail = [float(np.trapezoid(z[grid <= t + 1e-9], grid[grid <= t + 1e-9]) / total) for t in tail_below]
    return {"mean": m1, "sd": np.sqrt(np.maximum(m2 - m1**2, 0.0)), "tail_mass": tail,
            "density": z / total}


def check_importance(log_joint: LogDensity, axis: int, grid: np.ndarray, slices: dict[str, np.ndarray],
                     tail_below: tuple[float, ...], n: int = 20000, seed: int = 0,
                     df: float = 4.0) -> dict[str, Any]:
    """An independent check of :func:`integrate`: importance sampling of the whole posterior.

    Proposal: ``k`` uniform within grid cell ``i`` chosen with probability ``0.8 x`` the cell's
    mass under the slices' marginal ``+ 0.2 x`` its share of the range (defensive); the other
    parameters from a Student-t (df 4) on the conditional moments of the cell's nearer node,
    its sds widened 1.5 times (no correlations). Nothing here depends on the trapezoid rule or
    on the slices' ``log Z`` being right: an error there only lowers the ESS.

    Returns:
        ``mean``, ``sd`` (`D`), ``tail_mass`` (one per threshold), ``ess``, ``n``, and
        ``tail_mass_sd`` (delta-method Monte Carlo sd of the tail masses).
    """
    rng = np.random.default_rng([seed, 47])
    z = np.exp(slices["log_z"] - slices["log_z"].max())
    width = np.diff(grid)
    cell = 0.5 * (z[:-1] + z[1:]) * width
    prob = 0.8 * cell / cell.sum() + 0.2 * width / width.sum()
    which = rng.choice(width.size, n, p=prob)
    k = grid[which] + rng.random(n) * width[which]
    node = np.where(k - grid[which] < 0.5 * width[which], which, which + 1)
    rest = [j for j in range(slices["mean"].shape[1]) if j != axis]
    loc = slices["mean"][node][:, rest]
    sd = 1.5 * np.sqrt(slices["var"][node][:, rest])
    t = rng.standard_t(df, (n, len(rest)))
    x = np.empty((n, slices["mean"].shape[1]))
    x[:, rest], x[:, axis] = loc + sd * t, k
    log_q = (np.log(prob[which] / width[which])
             + stats.t.logpdf(t, df).sum(1) - np.log(sd).sum(1))
    log_p = np.concatenate([log_joint(b) for b in np.array_split(x, max(1, n // 1000))])
    w = _weights(log_p - log_q)
    mean = w @ x
    tails = np.stack([(x[:, axis] <= v).astype(float) for v in tail_below], 1)
    mass = w @ tails
    tail_sd = np.sqrt(np.sum(np.square(w[:, None] * (tails - mass)), 0))
    return {"mean": mean.tolist(), "sd": np.sqrt(w @ np.square(x - mean)).tolist(),
            "tail_mass": mass.tolist(), "tail_mass_sd": tail_sd.tolist(),
            "ess": float(1.0 / np.square(w).sum()), "n": n}

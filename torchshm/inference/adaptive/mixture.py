"""A Gaussian mixture with full covariances: the importance proposal of the final step.

PyVBMC's ``VariationalPosterior`` (the stored density, :func:`.sampling.fit_density`) gives
every component one width times a scale per coordinate shared by all components. Two modes
each narrow in one coordinate and far apart in it (two cracks whose positions swap: each
mode 0.04 m wide, the modes 7 m apart) make that scale the modes' distance, and the mixture
then covers the modes so loosely that importance sampling from it kept 6.5 effective draws
of 8,000. Components with their own full covariance have no such limit. The mixture lives
in the same unbounded coordinates as PyVBMC's (its ``ParameterTransformer``), so its
density in the original coordinates carries the transform's Jacobian.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pyvbmc.parameter_transformer import ParameterTransformer
from scipy.special import gammaln, logsumexp
from sklearn.mixture import GaussianMixture


@dataclass(frozen=True)
class Mixture:
    """Gaussian mixture in the unbounded coordinates of ``transformer``.

    Attributes:
        weights: `K` component weights (sum 1).
        means: `K x D` component means (unbounded coordinates).
        covariances: `K x D x D` component covariances, or scale matrices of the Student-t
            components (unbounded coordinates).
        transformer: PyVBMC's map between the original and the unbounded coordinates.
        df: `K` degrees of freedom of each component (``inf``: Gaussian); None: all Gaussian.
    """

    weights: np.ndarray
    means: np.ndarray
    covariances: np.ndarray
    transformer: ParameterTransformer
    df: np.ndarray | None = None

    @property
    def dofs(self) -> np.ndarray:
        """`K` degrees of freedom (``inf`` for a Gaussian component)."""
        return np.full(len(self.weights), np.inf) if self.df is None else np.asarray(self.df)

    def log_pdf(self, theta: np.ndarray) -> np.ndarray:
        """Log density `S` [nats] at ``theta`` `S x D` (original coordinates; -inf outside
        the support)."""
        theta = np.asarray(theta, dtype=np.float64)
        with np.errstate(invalid="ignore", divide="ignore"):
            z = np.asarray(self.transformer(theta), dtype=np.float64)
        inside = np.all(np.isfinite(z), axis=1)
        out = np.full(theta.shape[0], -np.inf)
        if inside.any():
            zi = z[inside]
            out[inside] = (self._log_pdf_unbounded(zi)
                           - np.asarray(self.transformer.log_abs_det_jacobian(zi)).reshape(-1))
        return out

    def _log_pdf_unbounded(self, z: np.ndarray) -> np.ndarray:
        chol = np.linalg.cholesky(self.covariances)  # K x D x D
        diff = z[None, :, :] - self.means[:, None, :]  # K x S x D
        white = np.linalg.solve(chol, diff.transpose(0, 2, 1))  # K x D x S
        half_logdet = np.log(np.diagonal(chol, axis1=1, axis2=2)).sum(-1)  # K
        dim, maha = z.shape[1], np.square(white).sum(1)  # K x S
        log_comp = np.empty_like(maha)
        for k, nu in enumerate(self.dofs):
            if np.isinf(nu):
                log_comp[k] = -0.5 * maha[k] - 0.5 * dim * np.log(2 * np.pi)
            else:
                log_comp[k] = (gammaln(0.5 * (nu + dim)) - gammaln(0.5 * nu)
                               - 0.5 * dim * np.log(nu * np.pi)
                               - 0.5 * (nu + dim) * np.log1p(maha[k] / nu))
        with np.errstate(divide="ignore"):
            log_w = np.log(self.weights)
        return logsumexp(log_comp - half_logdet[:, None] + log_w[:, None], axis=0)

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """``n`` draws `n x D` in the original coordinates."""
        comp = rng.choice(len(self.weights), size=int(n), p=self.weights)
        chol = np.linalg.cholesky(self.covariances)
        eps = rng.standard_normal((int(n), self.means.shape[1]))
        nu = self.dofs[comp]
        tail = np.isfinite(nu)  # a Student-t draw: a Gaussian one over sqrt(chi2 / nu)
        eps[tail] /= np.sqrt(rng.chisquare(nu[tail]) / nu[tail])[:, None]
        z = self.means[comp] + np.einsum("nij,nj->ni", chol[comp], eps)
        return np.asarray(self.transformer.inverse(z), dtype=np.float64)

    def widened(self, factor: float = 2.0, share: float = 0.3, df: float = np.inf) -> Mixture:
        """``(1 - share) self + share self'``, ``self'`` with every sd times ``factor`` and
        Student-t components of ``df`` degrees of freedom (``inf``: Gaussian): a defensive
        proposal, whose weights stay bounded where the target's tails are heavier."""
        return Mixture(np.concatenate([(1 - share) * self.weights, share * self.weights]),
                       np.concatenate([self.means, self.means]),
                       np.concatenate([self.covariances, factor ** 2 * self.covariances]),
                       self.transformer,
                       np.concatenate([self.dofs, np.full(len(self.weights), float(df))]))

    def defensive(self, box: np.ndarray, factor: float, share: float, slabs: float) -> Mixture:
        """The importance proposal built on this fit: :meth:`widened` by ``factor`` with
        ``share``, then :meth:`with_slabs` over ``box`` `D x 2` with the share ``slabs``."""
        return self.widened(factor, share).with_slabs(box, slabs)

    def with_slabs(self, box: np.ndarray, share: float = 0.2) -> Mixture:
        """``(1 - share) self + share S``: ``S`` holds, for each coordinate `d` in turn and
        each component, the component with coordinate `d` cut loose (its correlations dropped)
        and spread over the box: mean the centre of ``box`` `D x 2` (original coordinates),
        sd half its width, in unbounded coordinates. Draws of the other coordinates stay in
        the posterior's bulk while one coordinate roams the box: the proposal reaches a
        plateau that holds a few per cent of the posterior far from its bulk (a saturating
        stiffness up to its bound), which the chain, and a mixture fitted to it, barely saw.
        """
        ends = np.asarray(self.transformer(np.asarray(box, dtype=np.float64).T.copy()))
        centre, half = ends.mean(axis=0), 0.5 * np.abs(ends[1] - ends[0])
        dim, k = self.means.shape[1], len(self.weights)
        means = np.repeat(self.means[None], dim, axis=0)  # D x K x D
        covs = np.repeat(self.covariances[None], dim, axis=0)  # D x K x D x D
        for d in range(dim):
            means[d, :, d] = centre[d]
            covs[d, :, d, :] = 0.0
            covs[d, :, :, d] = 0.0
            covs[d, :, d, d] = half[d] ** 2
        return Mixture(np.concatenate([(1 - share) * self.weights,
                                       share * np.tile(self.weights, dim) / dim]),
                       np.concatenate([self.means, means.reshape(dim * k, dim)]),
                       np.concatenate([self.covariances, covs.reshape(dim * k, dim, dim)]),
                       self.transformer, np.concatenate([self.dofs, np.tile(self.dofs, dim)]))

    def pooled_covariance(self) -> np.ndarray:
        """`D x D` covariance within the components (their weighted mean), in the unbounded
        coordinates: the shape of one mode rather than the spread between modes."""
        return np.einsum("k,kde->de", self.weights, self.covariances)


def fit_mixture(samples: np.ndarray, transformer: ParameterTransformer, seed: int,
                max_components: int = 8, patience: int = 2) -> Mixture:
    """The full-covariance mixture that fits ``samples`` `S x D` best by BIC.

    Components are tried from one up; the search ends after ``patience`` numbers of
    components in a row that do not improve the best BIC, or at ``max_components``.
    """
    z = np.asarray(transformer(np.asarray(samples, dtype=np.float64)), dtype=np.float64)
    z = z[np.all(np.isfinite(z), axis=1)]
    center, scale = z.mean(axis=0), z.std(axis=0) + 1e-12
    u = (z - center) / scale  # sklearn's reg_covar is absolute: fit in standard units
    max_components = max(1, min(int(max_components), u.shape[0] // (2 * u.shape[1] + 2)))
    best = best_by_bic(u, "full", seed, max_components, patience)
    cov = best.covariances_ * scale[None, :, None] * scale[None, None, :]
    return Mixture(best.weights_.copy(), best.means_ * scale + center, cov, transformer)


def best_by_bic(u: np.ndarray, covariance_type: str, seed: int, max_components: int,
                patience: int | None = None, max_iter: int = 200) -> GaussianMixture:
    """sklearn's ``GaussianMixture`` of ``covariance_type`` that fits ``u`` `S x D` (standard
    units) best by BIC, trying 1 to ``max_components`` components; with ``patience``, the
    search ends after that many numbers of components in a row that do not improve it."""
    best, best_bic, worse = None, np.inf, 0
    for k in range(1, int(max_components) + 1):
        gm = GaussianMixture(k, covariance_type=covariance_type, random_state=seed,
                             reg_covar=1e-6, max_iter=max_iter)
        gm.fit(u)
        bic = gm.bic(u)
        if bic < best_bic:
            best, best_bic, worse = gm, bic, 0
        else:
            worse += 1
            if patience is not None and worse >= patience:
                break
    assert best is not None
    return best

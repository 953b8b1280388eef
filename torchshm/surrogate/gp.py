"""A GPyTorch GP whose many outputs share one kernel, fitted by its exact marginal likelihood.

Every output j (a load case and sensor) is an independent draw y_j ~ GP(0, k) of the same
zero-mean prior with the same kernel k and noise σ² (the paper's "shared hyperparameters").
With the `N x N` covariance ``C = K + σ² I`` of the design, the exact log marginal likelihood
of all `m` outputs is

    Σ_j log N(y_j; 0, C) = -½ tr(Yᵀ C⁻¹ Y) - (m / 2) log|C| - (m N / 2) log 2π,

which needs one Cholesky factor of C (O(N³)) and triangular solves with m right-hand sides
(O(N² m)); nothing grows with (m N)³. The model is a :class:`gpytorch.models.ExactGP` whose
training targets are the `m x N` batch of outputs; :class:`gpytorch.mlls.ExactMarginalLogLikelihood`
returns the `m` per-output terms, evaluated with ``fast_computations(log_prob=False)`` so that
the one Cholesky factor is broadcast over the outputs instead of being repeated for each.

The predictive mean of every output and the (shared) predictive variance of the latent
function follow from the same factor: ``mean = K_*ᵀ C⁻¹ Y``, ``var = k_** - K_*ᵀ C⁻¹ K_*``,
the equations GPyTorch's exact prediction strategy uses for a single output (GPyTorch's
eval-mode ``ExactGP`` does not accept a batch of targets with an unbatched kernel).

Why this and not another multi-output GP: a Kronecker multitask GP with the task covariance
fixed to I is also exact, but differentiates an eigendecomposition of K and its prediction path
forms `(T m) x (T m)` matrices; a batch GP with shared hyperparameters copies and factors C
once per output; a PCA basis is approximate. See ``docs/surrogate.md``.
"""

from __future__ import annotations

import math

import gpytorch
import numpy as np
import torch
from scipy.optimize import minimize
from threadpoolctl import threadpool_limits
from torch import Tensor

from torchshm.surrogate.warp import WarpedKernel

#: names of the kernels the surrogate offers: an ARD kernel of all inputs, or (``*_additive``)
#: that kernel plus one kernel of each input alone, ``k(x, x') = s0 k0(x, x') + Σ_i s_i k_i(x_i, x_i')``
#: (Duvenaud, Nickisch and Rasmussen 2011, "Additive Gaussian processes", first and last orders):
#: a response that is close to a sum of the inputs' effects (e.g. two cracks far apart) is
#: predicted where no run has that combination of inputs; ``*_warped``: any of these of inputs
#: read through a learned monotone warp each (:mod:`torchshm.surrogate.warp`: saturating inputs)
SURROGATE_KERNELS = ("rbf", "matern52", "rbf_additive", "matern52_additive",
                     "rbf_warped", "matern52_warped", "rbf_additive_warped", "matern52_additive_warped")


def widest_gap(values: Tensor) -> float:
    """The widest gap between successive distinct values of one input `N` (unit-box units),
    where the runs repeat some of its values (a grid or factorial design); 0 where every run has
    its own value (Latin hypercubes, posterior draws).

    The lower bound of an additive term's lengthscale: a kernel of one input alone cannot
    resolve that input's effect between the few values a grid gives it, and a term shorter than
    their gaps interpolates them with bumps (on a grid design of 4 values per input the marginal
    likelihood preferred a lengthscale of 0.03 and the field between the runs was off by 40 %).
    With every value distinct the data inform the term between them, and the bound is left
    out: on the emulator's adaptive designs (runs clustered at the posterior, a few far away)
    the widest gap is that between the cluster and the box's edge, and a bound there kept the
    term from the sharp effect of a damage's position (``sixth2_p4``, 2026-12-02: the wrong
    mode, 520 nats below the reference's log evidence, with a converged flag).
    """
    flat = values.detach().reshape(-1)
    distinct = torch.unique(flat)
    if distinct.numel() < 2 or distinct.numel() == flat.numel():
        return 0.0
    return float((distinct[1:] - distinct[:-1]).max())


class SharedKernelGP(gpytorch.models.ExactGP):
    """Zero-mean exact GP with `m` outputs that share one ARD kernel and one noise.

    Args:
        inputs: `N x d` training inputs (unit box).
        targets: `m x N` training targets, one row per output (standardised).
        kernel: one of :data:`SURROGATE_KERNELS`: "rbf" (squared exponential) or "matern52",
            with a lengthscale per input, or either plus one kernel per input (``_additive``),
            each also of warped inputs (``_warped``: :class:`~torchshm.surrogate.warp.WarpedKernel`).
        min_noise: lower bound of the noise variance (targets are deterministic model runs).
    """

    def __init__(self, inputs: Tensor, targets: Tensor, kernel: str = "rbf",
                 min_noise: float = 1e-10) -> None:
        if kernel not in SURROGATE_KERNELS:
            raise ValueError(f"kernel must be one of {SURROGATE_KERNELS}, got {kernel!r}")
        likelihood = gpytorch.likelihoods.GaussianLikelihood(
            noise_constraint=gpytorch.constraints.GreaterThan(min_noise))
        super().__init__(inputs, targets, likelihood)
        d = inputs.shape[-1]

        def base(**kwargs: object) -> gpytorch.kernels.Kernel:
            return (gpytorch.kernels.RBFKernel(**kwargs) if kernel.startswith("rbf")
                    else gpytorch.kernels.MaternKernel(nu=2.5, **kwargs))

        self.mean_module = gpytorch.means.ZeroMean()
        covar: gpytorch.kernels.Kernel = gpytorch.kernels.ScaleKernel(base(ard_num_dims=d))
        self.floors: list[float] = [0.0]
        if kernel.removesuffix("_warped").endswith("_additive"):
            for i in range(d):
                floor = widest_gap(inputs[..., i])
                self.floors.append(floor)
                term = base(active_dims=(i,), lengthscale_constraint=gpytorch.constraints.GreaterThan(floor))
                covar = covar + gpytorch.kernels.ScaleKernel(term)
        self.covar_module = WarpedKernel(covar, d) if kernel.endswith("_warped") else covar
        self.kernel, self.min_noise = kernel, min_noise
        self._factor: Tensor | None = None
        self._weights: Tensor | None = None
        self.to(torch.float64)

    def forward(self, x: Tensor) -> gpytorch.distributions.MultivariateNormal:
        """Prior of the latent function at `T x d` inputs."""
        return gpytorch.distributions.MultivariateNormal(self.mean_module(x), self.covar_module(x))

    def log_marginal_likelihood(self) -> Tensor:
        """Exact log marginal likelihood per output and training point, `m` (GPyTorch MLL)."""
        mll = gpytorch.mlls.ExactMarginalLogLikelihood(self.likelihood, self)
        with gpytorch.settings.fast_computations(log_prob=False):
            value = mll(self(*self.train_inputs), self.train_targets)
        if isinstance(self.covar_module, WarpedKernel):  # its prior, weighed as one output's
            value = value + self.covar_module.warp.log_prior() / self.train_targets.shape[-1]
        return value

    def fit(self, lengthscales: tuple[float, ...] = (0.2, 0.5, 1.0), max_iter: int = 200,
            warm: dict[str, Tensor] | None = None) -> float:
        """Maximise the marginal likelihood by L-BFGS from several initial lengthscales.

        Args:
            lengthscales: initial lengthscale (unit-box units) of each restart.
            max_iter: L-BFGS iterations per restart.
            warm: hyperparameters of an earlier fit (:meth:`hyperparameters`) to start one
                more restart from, first (a warm start when the design has grown a little).

        Returns:
            The best mean log marginal likelihood per output and training point.
        """
        best, best_state = -math.inf, None
        starts: list[float | dict[str, Tensor]] = ([warm] if warm else []) + list(lengthscales)
        for start in starts:
            if isinstance(start, dict):  # the values, not the earlier design's bounds
                self.load_state_dict({k: v for k, v in start.items() if "_constraint." not in k},
                                     strict=False)
            else:
                self._initialise(start)
            value = self._optimise(max_iter)
            if value > best:
                best, best_state = value, {k: v.clone() for k, v in self.state_dict().items()}
        if best_state is None:
            raise RuntimeError("surrogate GP: every marginal-likelihood optimisation failed")
        self.load_state_dict(best_state)
        self.freeze()
        return best

    def hyperparameters(self) -> dict[str, Tensor]:
        """A copy of the fitted hyperparameters (raw kernel and noise parameters), for
        :meth:`fit`'s warm start of a GP on a grown design."""
        return {k: v.detach().clone() for k, v in self.state_dict().items()}

    def scale_kernels(self) -> list[gpytorch.kernels.ScaleKernel]:
        """The kernel's terms: the ARD kernel of all inputs first, then (additive kernels)
        one per input."""
        covar = self.covar_module.base if isinstance(self.covar_module, WarpedKernel) else self.covar_module
        if isinstance(covar, gpytorch.kernels.ScaleKernel):
            return [covar]
        return list(covar.kernels)

    def _initialise(self, lengthscale: float) -> None:
        terms = self.scale_kernels()
        for i, term in enumerate(terms):
            start = max(lengthscale, 1.5 * self.floors[i])  # floors: one per term (0: none)
            term.base_kernel.lengthscale = torch.full_like(term.base_kernel.lengthscale, start)
            # the joint term holds most of the prior variance at the start, each input's a share
            term.outputscale = 1.0 if len(terms) == 1 else (0.5 if i == 0 else 0.5 / (len(terms) - 1))
        self.likelihood.noise = max(1e-6, 10 * self.min_noise)
        if isinstance(self.covar_module, WarpedKernel):
            self.covar_module.warp.reset()

    def _optimise(self, max_iter: int) -> float:
        """L-BFGS-B (SciPy) on the raw hyperparameters from their current values, at most
        `max_iter` iterations; the mean log marginal likelihood reached (-inf on failure).

        SciPy's optimiser rather than ``torch.optim.LBFGS``: the first ``torch.optim``
        optimiser of a process imports ``torch._dynamo`` (about 2 s of CPU, once per process,
        in every command that fits an emulator). NumPy's and SciPy's OpenBLAS are held to one
        thread meanwhile: beside torch's own threads, theirs spin between the optimiser's tiny
        steps (measured: 2-4x the fit's CPU time with 2 threads each on 2 cores)."""
        self.train()
        params = list(self.parameters())
        for p in params:
            p.requires_grad_(True)
        start = torch.cat([p.detach().reshape(-1) for p in params]).numpy().astype(np.float64)

        def load(v: np.ndarray) -> None:
            flat = torch.as_tensor(v, dtype=torch.float64)
            with torch.no_grad():
                offset = 0
                for p in params:
                    p.copy_(flat[offset:offset + p.numel()].reshape(p.shape))
                    offset += p.numel()

        def loss_and_grad(v: np.ndarray) -> tuple[float, np.ndarray]:
            load(v)
            for p in params:
                p.grad = None
            try:
                loss = -self.log_marginal_likelihood().mean()
                loss.backward()
            except (RuntimeError, ValueError):  # a failed Cholesky factor: make the step shorter
                return math.inf, np.zeros_like(v)
            grad = torch.cat([(p.grad if p.grad is not None else torch.zeros_like(p)).reshape(-1)
                              for p in params])
            value = float(loss.detach())
            if not math.isfinite(value) or not bool(torch.isfinite(grad).all()):
                return math.inf, np.zeros_like(v)
            return value, grad.numpy().astype(np.float64)

        with threadpool_limits(limits=1, user_api="blas"):  # NumPy/SciPy's OpenBLAS threads
            result = minimize(loss_and_grad, start, jac=True, method="L-BFGS-B",
                              options={"maxiter": int(max_iter), "maxfun": int(1.25 * max_iter) + 1,
                                       "maxcor": 50, "ftol": 1e-10, "gtol": 1e-7})
        load(result.x)
        try:
            with torch.no_grad():
                value = float(self.log_marginal_likelihood().mean())
        except (RuntimeError, ValueError):
            return -math.inf
        return value if math.isfinite(value) else -math.inf

    def freeze(self) -> None:
        """Fix the hyperparameters and cache the Cholesky factor and the weights C⁻¹ Y."""
        self.eval()
        for p in self.parameters():
            p.requires_grad_(False)
        inputs = self.train_inputs[0]
        covar = self.likelihood(self.forward(inputs)).lazy_covariance_matrix
        self._factor = covar.cholesky().to_dense()
        self._weights = torch.cholesky_solve(self.train_targets.mT, self._factor)

    @property
    def factor(self) -> Tensor:
        """`N x N` lower Cholesky factor of the training covariance (cached by :meth:`freeze`)."""
        if self._factor is None:
            self.freeze()
        return self._factor

    @property
    def weights(self) -> Tensor:
        """`N x m` weights ``C⁻¹ Y`` of the posterior mean (cached by :meth:`freeze`)."""
        if self._weights is None:
            self.freeze()
        return self._weights

    def cross_covariance(self, x: Tensor) -> Tensor:
        """`T x N` prior covariance between `T x d` inputs and the training inputs."""
        return self.covar_module(x, self.train_inputs[0]).to_dense()

    def latent_variance(self, x: Tensor, cross: Tensor) -> Tensor:
        """Posterior variance `T x 1` of the latent function, shared by all outputs."""
        if self._factor is None:
            self.freeze()
        solved = torch.linalg.solve_triangular(self._factor, cross.mT, upper=False)
        prior = self.covar_module(x, diag=True)
        return (prior - solved.square().sum(dim=-2)).clamp_min(0.0).unsqueeze(-1)

    def predict(self, x: Tensor, variance: bool = True) -> tuple[Tensor, Tensor | None]:
        """Posterior of the latent functions at `T x d` inputs.

        Returns:
            The mean `T x m` of every output and, when asked, the latent variance `T x 1`
            shared by all outputs (standardised units).
        """
        cross = self.cross_covariance(x)
        return cross @ self.weights, self.latent_variance(x, cross) if variance else None

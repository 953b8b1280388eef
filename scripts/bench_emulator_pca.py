"""Per-principal-component GPs against the shared-kernel field emulator, in log-likelihood units.

The field emulator of ``method="emulator"`` is one GPyTorch GP whose outputs (every load case
and reading) share one ARD kernel (:mod:`torchshm.surrogate.gp`). A common alternative gives
each principal component of the runs' fields its own GP and kernel (a separate lengthscale per
component and input). This script measures whether that would make the emulator more accurate
where the method needs it, on the same designs and test points as
``scripts/bench_emulator_error.py`` (a Latin hypercube of the plausible box, then draws of the
reference posterior; test points "far", uniform in the plausible box, and "near", within 2
reference sd of the posterior): the error of the emulated log-likelihood,
``|ℓ(true strains) - ℓ(emulator mean)|`` (Eq. 21, the same covariance both times), for

- ``shared``: the method's emulator (:class:`~torchshm.inference.adaptive.field.FieldEmulator`);
- ``pca``: on the same standardised targets, the SVD of the `m x N` targets, and for each
  component (singular value above 1e-8 of the largest) an independent exact GP of its scores
  (Matérn 5/2, ARD, an output scale and a noise, GPyTorch batch of independent models, L-BFGS
  from the lengthscales 0.2, 0.5 and 1, the best per component); its mean is the components'
  predicted scores times their loadings.

Usage::

    OMP_NUM_THREADS=1 .venv/bin/python scripts/bench_emulator_pca.py [--cases NAME ...] [--points N]
"""

from __future__ import annotations

import os
import statistics
import sys
import time
from pathlib import Path

import gpytorch
import numpy as np
import torch

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))

from bench_emulator_error import emulators_at_designs, rows_of  # noqa: E402


class _Scores(gpytorch.models.ExactGP):
    """`K` independent exact GPs (a batch) of the components' scores."""

    def __init__(self, x: torch.Tensor, y: torch.Tensor, likelihood: gpytorch.likelihoods.Likelihood) -> None:
        super().__init__(x, y, likelihood)
        batch = torch.Size([y.shape[0]])
        self.mean_module = gpytorch.means.ZeroMean(batch_shape=batch)
        self.covar_module = gpytorch.kernels.ScaleKernel(
            gpytorch.kernels.MaternKernel(nu=2.5, ard_num_dims=x.shape[-1], batch_shape=batch), batch_shape=batch)

    def forward(self, x: torch.Tensor) -> gpytorch.distributions.MultivariateNormal:
        return gpytorch.distributions.MultivariateNormal(self.mean_module(x), self.covar_module(x))


class ComponentGPs:
    """A GP per principal component of `m x N` standardised targets over `N x d` inputs."""

    def __init__(self, inputs: torch.Tensor, targets: torch.Tensor) -> None:
        u, s, vh = torch.linalg.svd(targets, full_matrices=False)
        keep = s > s[0] * 1e-8
        self.loadings, scores = u[:, keep], s[keep, None] * vh[keep]  # m x K, K x N
        self.scale = scores.std(-1, keepdim=True).clamp_min(1e-300)
        y = scores / self.scale
        k, n = y.shape
        self.x = inputs.expand(k, n, inputs.shape[-1]).contiguous()
        fits = []
        for lengthscale in (0.2, 0.5, 1.0):
            gp = self._model(y)
            gp.covar_module.base_kernel.lengthscale = torch.full_like(gp.covar_module.base_kernel.lengthscale, lengthscale)
            gp.likelihood.noise = torch.full((k, 1), 1e-6, dtype=torch.float64)
            mll = gpytorch.mlls.ExactMarginalLogLikelihood(gp.likelihood, gp)
            gp.train()
            optimiser = torch.optim.LBFGS(gp.parameters(), lr=1.0, max_iter=100, line_search_fn="strong_wolfe")

            def closure() -> torch.Tensor:
                optimiser.zero_grad()
                loss = -mll(gp(self.x), y).sum()
                loss.backward()
                return loss

            try:
                optimiser.step(closure)
                with torch.no_grad():
                    value = mll(gp(self.x), y)
            except (RuntimeError, ValueError):
                continue
            fits.append((torch.nan_to_num(value, nan=-np.inf), {key: v.detach().clone() for key, v in gp.state_dict().items()}))
        pick = torch.stack([f[0] for f in fits]).argmax(0)
        state = {key: (torch.stack([f[1][key] for f in fits])[pick, torch.arange(k)]
                       if fits[0][1][key].dim() >= 1 and fits[0][1][key].shape[0] == k else fits[0][1][key])
                 for key in fits[0][1]}
        self.gp = self._model(y)
        self.gp.load_state_dict(state)
        self.gp.eval()
        with torch.no_grad():
            cov = self.gp.covar_module(self.x).to_dense() + self.gp.likelihood.noise.unsqueeze(-1) * torch.eye(n, dtype=torch.float64)
            self.weights = torch.cholesky_solve(y.unsqueeze(-1), torch.linalg.cholesky(cov))

    def _model(self, y: torch.Tensor) -> _Scores:
        likelihood = gpytorch.likelihoods.GaussianLikelihood(
            batch_shape=torch.Size([y.shape[0]]), noise_constraint=gpytorch.constraints.GreaterThan(1e-10))
        return _Scores(self.x, y, likelihood).double()

    def mean(self, inputs: torch.Tensor) -> torch.Tensor:
        """Predicted standardised targets `T x m` at `T x d` inputs."""
        with torch.no_grad():
            cross = self.gp.covar_module(inputs.expand(self.x.shape[0], *inputs.shape), self.x).to_dense()
            return ((cross @ self.weights).squeeze(-1) * self.scale).mT @ self.loadings.mT


def run_case(name: str, n_points: int, designs: tuple[tuple[int, int], ...], seed: int = 0) -> list[dict]:
    """Rows of the two emulators' log-likelihood errors for one case: one per design and test set."""
    out, pca, fitted = [], None, None
    for problem, emulator, log_joint, runs, label, test, true in emulators_at_designs(name, n_points, designs, seed):
        if emulator is not fitted:  # one per design, for both test sets
            start = time.process_time()
            pca = ComponentGPs(emulator.surrogate.gp.train_inputs[0], emulator.surrogate.gp.train_targets)
            cpu, fitted = time.process_time() - start, emulator
        rows, tr = torch.as_tensor(test), emulator.surrogate.transform
        tp = problem.split.physical(rows)
        shared = emulator.predict_mean(tp)
        pca_mean = ((tr.offset + pca.mean(tr.inputs(tp)) * tr.scale) * tr.factor(tp)).reshape(shared.shape)
        exact = log_joint.at(true, None, rows)
        err = {k: np.abs(log_joint.at(m, None, rows) - exact) for k, m in (("shared", shared), ("pca", pca_mean))}
        row = {"case": name, "P": len(problem.physical_names), "runs": runs, "test": label,
               "components": int(pca.loadings.shape[1]), "pca_fit_cpu_s": cpu,
               **{f"median_{k}": float(np.median(v)) for k, v in err.items()},
               **{f"p90_{k}": float(np.quantile(v, 0.9)) for k, v in err.items()}}
        out.append(row)
        print(f"{name:18s} {runs:3d} runs {label:4s} K={row['components']:2d} median |Δ| shared "
              f"{row['median_shared']:9.3g} pca {row['median_pca']:9.3g} | 90 % shared {row['p90_shared']:9.3g} "
              f"pca {row['p90_pca']:9.3g}", flush=True)
    return out


def main() -> None:
    rows = rows_of(run_case, __doc__.splitlines()[0], 100)
    print("\n| runs | test points | median over cases of median \\|Δ\\| shared / pca [nat] | median ratio "
          "pca / shared | cases pca 2× better / 2× worse | median 90 % \\|Δ\\| shared / pca [nat] |")
    print("| ---: | --- | ---: | ---: | ---: | ---: |")
    for runs in sorted({r["runs"] for r in rows}):
        for label in ("far", "near"):
            sel = [r for r in rows if r["runs"] == runs and r["test"] == label]
            if not sel:
                continue
            ratio = [r["median_pca"] / max(r["median_shared"], 1e-300) for r in sel]
            print(f"| {runs} | {label} | {statistics.median(r['median_shared'] for r in sel):.3g} / "
                  f"{statistics.median(r['median_pca'] for r in sel):.3g} | {statistics.median(ratio):.2f} | "
                  f"{sum(q < 0.5 for q in ratio)} / {sum(q > 2 for q in ratio)} of {len(sel)} | "
                  f"{statistics.median(r['p90_shared'] for r in sel):.3g} / "
                  f"{statistics.median(r['p90_pca'] for r in sel):.3g} |")
    print("load average at the end " + ", ".join(f"{x:.1f}" for x in os.getloadavg()))


if __name__ == "__main__":
    main()

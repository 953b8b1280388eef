"""The shared-kernel GP: its marginal likelihood and predictions against GPyTorch and theory."""

from __future__ import annotations

import gpytorch
import pytest
import torch

from torchshm.surrogate import SharedKernelGP


@pytest.fixture
def data() -> tuple[torch.Tensor, torch.Tensor]:
    g = torch.Generator().manual_seed(3)
    inputs = torch.rand(20, 2, generator=g, dtype=torch.float64)
    weights = torch.randn(2, 7, generator=g, dtype=torch.float64)
    targets = torch.sin(3.0 * inputs @ weights).mT.contiguous()  # 7 outputs x 20 points
    return inputs, targets


def _set(gp: SharedKernelGP) -> None:
    gp.covar_module.base_kernel.lengthscale = torch.tensor([[0.3, 0.7]])
    gp.covar_module.outputscale = 1.3
    gp.likelihood.noise = 1e-4


def test_log_marginal_likelihood_is_the_sum_over_independent_outputs(data) -> None:
    inputs, targets = data
    gp = SharedKernelGP(inputs, targets)
    _set(gp)
    covar = gp.covar_module(inputs).to_dense() + 1e-4 * torch.eye(20, dtype=torch.float64)
    normal = torch.distributions.MultivariateNormal(torch.zeros(20, dtype=torch.float64), covar)
    expected = normal.log_prob(targets) / 20.0  # GPyTorch's MLL is per training point
    torch.testing.assert_close(gp.log_marginal_likelihood(), expected, rtol=1e-10, atol=1e-10)


def test_predictions_equal_gpytorch_exact_prediction_for_each_output(data) -> None:
    inputs, targets = data
    gp = SharedKernelGP(inputs, targets)
    _set(gp)
    gp.freeze()
    test = torch.rand(9, 2, generator=torch.Generator().manual_seed(4), dtype=torch.float64)
    mean, var = gp.predict(test)
    for j in (0, 4):
        single = SharedKernelGP(inputs, targets[j])
        single.load_state_dict(gp.state_dict())
        single.eval()
        with torch.no_grad():
            latent = single(test)
        torch.testing.assert_close(mean[:, j], latent.mean, rtol=1e-8, atol=1e-8)
        torch.testing.assert_close(var[:, 0], latent.variance, rtol=1e-6, atol=1e-10)


def test_fit_increases_the_marginal_likelihood_and_freezes(data) -> None:
    inputs, targets = data
    gp = SharedKernelGP(inputs, targets, kernel="matern52")
    gp._initialise(0.5)
    with torch.no_grad():
        before = float(gp.log_marginal_likelihood().mean())
    after = gp.fit(lengthscales=(0.5,), max_iter=50)
    assert after > before
    assert not any(p.requires_grad for p in gp.parameters())
    assert float(gp.likelihood.noise) >= gp.min_noise


def test_variance_is_small_at_training_points_and_non_negative(data) -> None:
    inputs, targets = data
    gp = SharedKernelGP(inputs, targets)
    gp.fit(max_iter=50)
    mean, var = gp.predict(inputs)
    far = gp.predict(torch.tensor([[3.0, -2.0]], dtype=torch.float64))[1]
    assert bool((var >= 0).all())
    assert float(var.max()) < 1e-3 * float(far.min())
    torch.testing.assert_close(mean, targets.mT, rtol=0, atol=1e-3)


def test_unknown_kernel_is_refused(data) -> None:
    with pytest.raises(ValueError, match="kernel"):
        SharedKernelGP(*data, kernel="cubic")


def test_gpytorch_model_and_mll_are_used(data) -> None:
    gp = SharedKernelGP(*data)
    assert isinstance(gp, gpytorch.models.ExactGP)
    assert isinstance(gp.likelihood, gpytorch.likelihoods.GaussianLikelihood)


def test_fit_reaches_the_optimum_that_torch_lbfgs_finds(data) -> None:
    """SciPy's L-BFGS-B (the fit) against torch's own L-BFGS from the same start: the same
    maximum of the mean log marginal likelihood to 1e-6 per training point."""
    inputs, targets = data
    gp = SharedKernelGP(inputs, targets)
    value = gp.fit(lengthscales=(0.5,), max_iter=200)

    other = SharedKernelGP(inputs, targets)
    other._initialise(0.5)
    other.train()
    optimiser = torch.optim.LBFGS(other.parameters(), lr=1.0, max_iter=500, line_search_fn="strong_wolfe",
                                  tolerance_grad=1e-10, tolerance_change=1e-14)

    def closure() -> torch.Tensor:
        optimiser.zero_grad()
        loss = -other.log_marginal_likelihood().mean()
        loss.backward()
        return loss

    optimiser.step(closure)
    with torch.no_grad():
        expected = float(other.log_marginal_likelihood().mean())
    assert value == pytest.approx(expected, abs=1e-6)


def test_fitting_does_not_import_torch_dynamo() -> None:
    """The fit uses no ``torch.optim`` optimiser, whose first use imports ``torch._dynamo``
    (about 2 s of CPU in every process that fits an emulator)."""
    import subprocess
    import sys

    code = ("import sys, torch\nfrom torchshm.surrogate import SharedKernelGP\n"
            "x = torch.rand(12, 2, dtype=torch.float64)\n"
            "SharedKernelGP(x, torch.sin(3 * x).mT.contiguous()).fit(max_iter=20)\n"
            "print('torch._dynamo' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"

"""The shared-kernel GP: its marginal likelihood and predictions against GPyTorch and theory."""

from __future__ import annotations

import gpytorch
import pytest
import torch

from torchshm.surrogate import SharedKernelGP
from torchshm.surrogate.gp import widest_gap


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


def _matern52(r: torch.Tensor) -> torch.Tensor:
    """Matérn 5/2 correlation of scaled distances ``r``."""
    s = 5.0**0.5 * r
    return (1.0 + s + s.square() / 3.0) * torch.exp(-s)


def test_additive_kernel_is_the_joint_term_plus_one_term_per_input(data) -> None:
    inputs, targets = data
    gp = SharedKernelGP(inputs, targets, kernel="matern52_additive")
    joint, first, second = gp.scale_kernels()
    joint.base_kernel.lengthscale = torch.tensor([[0.3, 0.7]])
    joint.outputscale, first.outputscale, second.outputscale = 1.3, 0.4, 0.2
    first.base_kernel.lengthscale, second.base_kernel.lengthscale = 0.5, 0.9
    x = inputs[:6]
    scaled = (x[:, None, :] - x[None, :, :]) / torch.tensor([0.3, 0.7], dtype=torch.float64)
    expected = (1.3 * _matern52(scaled.norm(dim=-1))
                + 0.4 * _matern52((x[:, None, 0] - x[None, :, 0]).abs() / 0.5)
                + 0.2 * _matern52((x[:, None, 1] - x[None, :, 1]).abs() / 0.9))
    torch.testing.assert_close(gp.covar_module(x).to_dense(), expected, rtol=1e-10, atol=1e-12)


def test_additive_kernel_carries_a_sum_of_effects_to_an_unseen_combination() -> None:
    # f(x) = sin(4 x1) + (x2 - 0.3)^2 known along the two lines x1 = 0.1 and x2 = 0.1 only:
    # the corner (0.9, 0.9) combines inputs no run has. A sum of effects is predicted there
    # exactly by f(0.9, 0.1) + f(0.1, 0.9) - f(0.1, 0.1); the additive kernel should come close
    # (within 0.05 of a range of about 2), the product kernel should not
    line = torch.linspace(0.0, 1.0, 9, dtype=torch.float64)
    inputs = torch.cat([torch.stack([line, torch.full_like(line, 0.1)], -1),
                        torch.stack([torch.full_like(line, 0.1), line], -1)])

    def f(x: torch.Tensor) -> torch.Tensor:
        return torch.sin(4.0 * x[:, 0]) + (x[:, 1] - 0.3).square()

    targets = f(inputs)[None].repeat(3, 1)
    corner = torch.tensor([[0.9, 0.9]], dtype=torch.float64)
    errors = {}
    for kernel in ("matern52", "matern52_additive"):
        gp = SharedKernelGP(inputs, targets, kernel=kernel)
        gp.fit(lengthscales=(0.5,), max_iter=200)
        errors[kernel] = float((gp.predict(corner)[0][0, 0] - f(corner)[0]).abs())
    assert errors["matern52_additive"] < 0.05
    assert errors["matern52"] > 4 * errors["matern52_additive"]


def test_additive_terms_do_not_interpolate_a_grid_with_bumps() -> None:
    # on a 4 x 4 grid each input has 4 values, 1/3 apart; a one-input term shorter than that
    # fits them exactly with bumps between: without the floor (the widest gap) the marginal
    # likelihood took a lengthscale of 0.03 on this field, off by 2.7 µε (rms) between the
    # runs against 0.039 for the ARD kernel alone; with it, 0.061
    from torchshm.surrogate import Surrogate
    from torchshm.surrogate.field import fit_field

    x = torch.linspace(0.0, 3.0, 40, dtype=torch.float64)

    def wave(t: torch.Tensor) -> torch.Tensor:  # 8 sin((2 + a) x) + 4 b² cos(x) [µε]
        a, b = t[..., 0, None, None], t[..., 1, None, None]
        return 8.0 * torch.sin((2.0 + a) * x) + 4.0 * b**2 * torch.cos(x)

    side = torch.linspace(0.0, 1.0, 4, dtype=torch.float64)
    theta = torch.stack(torch.meshgrid(side, side, indexing="ij"), -1).reshape(-1, 2)
    test = torch.rand(200, 2, generator=torch.Generator().manual_seed(6), dtype=torch.float64)
    errors = {}
    for kernel in ("matern52", "matern52_additive"):
        fit = fit_field(theta, wave(theta), kernel=kernel)
        sur = Surrogate(fit.gp, fit.transform, x, torch.zeros(1, dtype=torch.float64), ("a", "b"),
                        "wave", fit.theta_p, fit.outputs)
        errors[kernel] = float((sur.predict(test, variance=False)[0] - wave(test)).square().mean().sqrt())
    assert fit.gp.floors == pytest.approx([0.0, 1.0 / 3.0, 1.0 / 3.0])
    assert all(float(t.base_kernel.lengthscale.min()) >= 1.0 / 3.0 - 1e-9 for t in fit.gp.scale_kernels()[1:])
    assert errors["matern52_additive"] < 3.0 * errors["matern52"]


def test_a_warm_start_keeps_the_new_designs_floors() -> None:
    # the earlier fit's state holds its own bounds (a wider gap with fewer runs); a warm start
    # takes its values only, so a start at the new floor is allowed
    coarse = torch.tensor([[0.0], [0.6], [0.6], [1.0]], dtype=torch.float64)  # a value repeated
    fine = torch.tensor([[0.0], [0.3], [0.3], [0.6], [0.8], [1.0]], dtype=torch.float64)
    first = SharedKernelGP(coarse, torch.sin(3.0 * coarse).mT, kernel="matern52_additive")
    first.fit(lengthscales=(0.5,), max_iter=20)
    second = SharedKernelGP(fine, torch.sin(3.0 * fine).mT, kernel="matern52_additive")
    second.fit(lengthscales=(0.2,), max_iter=20, warm=first.hyperparameters())
    assert second.floors[1] == pytest.approx(0.3)
    assert float(second.scale_kernels()[1].base_kernel.raw_lengthscale_constraint.lower_bound) == pytest.approx(0.3)


def test_distinct_run_values_leave_the_additive_terms_unbounded() -> None:
    # every run at its own value (a Latin hypercube, posterior draws): no floor; a repeated
    # value (a grid): the widest gap
    assert widest_gap(torch.tensor([0.0, 0.1, 0.7, 1.0], dtype=torch.float64)) == 0.0
    assert widest_gap(torch.tensor([0.0, 0.1, 0.1, 0.7, 1.0], dtype=torch.float64)) == pytest.approx(0.6)
    x = torch.rand(12, 2, generator=torch.Generator().manual_seed(3), dtype=torch.float64)
    gp = SharedKernelGP(x, torch.sin(3.0 * x[:, :1]).mT, kernel="matern52_additive")
    assert gp.floors == [0.0, 0.0, 0.0]

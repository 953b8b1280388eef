"""fit_surrogate on a stand-in frame: accuracy, the forward-model contract, failures, store."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from standin_frame import StandInFrame
from torchshm.forward.protocol import ForwardModel
from torchshm.surrogate import Surrogate, fit_surrogate, grid_design, load_surrogate


def _random_theta(n: int, seed: int) -> torch.Tensor:
    g = torch.Generator().manual_seed(seed)
    return torch.stack([10 + 90 * torch.rand(n, generator=g, dtype=torch.float64),
                        12 * torch.rand(n, generator=g, dtype=torch.float64)], dim=-1)


def test_accurate_away_from_the_design(fitted: Surrogate, standin: StandInFrame) -> None:
    theta = _random_theta(40, seed=1)
    truth = standin(theta)
    error = (fitted(theta) - truth).abs().amax(dim=(-2, -1))
    assert float((error / truth.abs().amax(dim=(-2, -1))).max()) < 1e-3


def test_is_a_forward_model(fitted: Surrogate, standin: StandInFrame) -> None:
    assert isinstance(fitted, ForwardModel)
    torch.testing.assert_close(fitted.x, standin.x)
    torch.testing.assert_close(fitted.loads, standin.loads)
    assert fitted.names == ("E_c", "log10_K_r")
    assert fitted.model_identity == standin.identity and fitted.identity != standin.identity
    theta = _random_theta(12, seed=2)
    batched = fitted(theta.reshape(3, 4, 2))
    assert batched.shape == (3, 4, 3, 25) and batched.dtype == torch.float64
    loop = torch.stack([fitted(row) for row in theta])
    assert loop.shape == (12, 3, 25)
    torch.testing.assert_close(batched.reshape(12, 3, 25), loop, rtol=1e-9, atol=1e-8)
    from_numpy = fitted(theta.numpy())
    assert isinstance(from_numpy, torch.Tensor)
    torch.testing.assert_close(from_numpy, loop, rtol=1e-9, atol=1e-8)


def test_variance_shape_sign_and_size(fitted: Surrogate, small_design: torch.Tensor) -> None:
    theta = _random_theta(30, seed=3)
    var = fitted.variance(theta.reshape(5, 6, 2))
    assert var.shape == (5, 6, 3, 25) and bool((var >= 0).all())
    at_design = fitted.variance(small_design)
    peak = float(fitted.outputs.abs().max())
    assert float(at_design.max()) < (1e-4 * peak) ** 2
    assert float(fitted.variance(torch.tensor([60.0, 30.0])).max()) > float(at_design.max())


def test_gradient_matches_finite_differences(fitted: Surrogate) -> None:
    theta = torch.tensor([37.0, 7.3], dtype=torch.float64, requires_grad=True)
    fitted(theta).sum().backward()
    step = torch.tensor([1e-4, 1e-5], dtype=torch.float64)
    numeric = torch.stack([
        (fitted(theta.detach() + step[i] * e).sum() - fitted(theta.detach() - step[i] * e).sum())
        / (2 * step[i]) for i, e in enumerate(torch.eye(2, dtype=torch.float64))])
    torch.testing.assert_close(theta.grad, numeric, rtol=1e-5, atol=1e-7)


def test_save_and_load_give_identical_predictions(fitted: Surrogate, tmp_path) -> None:
    path = tmp_path / "sur.pt"
    fitted.save(path)
    again = load_surrogate(path)
    theta = _random_theta(20, seed=4)
    assert torch.equal(again(theta), fitted(theta))
    assert torch.equal(again.variance(theta), fitted.variance(theta))
    assert again.identity == fitted.identity and again.names == fitted.names
    assert isinstance(torch.load(path, weights_only=True), dict)


def test_not_a_surrogate_file_is_refused(tmp_path) -> None:
    path = tmp_path / "other.pt"
    torch.save({"format": "something"}, path)
    with pytest.raises(ValueError, match="not a torchshm surrogate"):
        load_surrogate(path)


def test_wrong_parameter_count_is_refused(fitted: Surrogate) -> None:
    with pytest.raises(ValueError, match="2 parameters"):
        fitted(torch.zeros(4, 3))


class FailingFrame(StandInFrame):
    """Raises for the stiffest concrete of the design."""

    identity = "failing-stand-in/1"

    def __call__(self, theta_p: torch.Tensor) -> torch.Tensor:
        if bool((torch.as_tensor(theta_p)[..., 0] > 99.0).any()):
            raise RuntimeError("solver diverged")
        return super().__call__(theta_p)


def test_failed_design_runs_are_left_out_with_a_warning() -> None:
    design = grid_design(torch.linspace(10.0, 100.0, 4), torch.linspace(0.0, 12.0, 6))
    with pytest.warns(UserWarning, match=r"6 of 24 design evaluations failed.*row 18.*diverged"):
        sur = fit_surrogate(FailingFrame(), design, lengthscales=(0.5,), max_iter=50)
    assert sur.theta_p.shape == (18, 2) and bool((sur.theta_p[:, 0] < 99.0).all())


def test_too_few_successful_runs_is_an_error() -> None:
    design = torch.tensor([[100.0, 1.0], [100.0, 2.0], [50.0, 1.0]], dtype=torch.float64)
    with pytest.warns(UserWarning), pytest.raises(ValueError, match="only 1 distinct"):
        fit_surrogate(FailingFrame(), design)


def test_store_resumes_without_new_model_runs(tmp_path) -> None:
    design = grid_design(torch.linspace(10.0, 100.0, 3), torch.linspace(0.0, 12.0, 5))
    model, store = StandInFrame(), tmp_path / "store.sqlite"
    first = fit_surrogate(model, design, store=store, lengthscales=(0.5,), max_iter=50)
    assert model.calls == 15
    second = fit_surrogate(model, design, store=store, lengthscales=(0.5,), max_iter=50)
    assert model.calls == 15
    np.testing.assert_array_equal(second.outputs.numpy(), first.outputs.numpy())


class SmoothModel(StandInFrame):
    """A smooth response without elastic structure (not ∝ 1 / E)."""

    identity = "smooth-stand-in/1"

    def __call__(self, theta_p: torch.Tensor) -> torch.Tensor:
        theta = torch.as_tensor(theta_p, dtype=torch.float64)
        a, b = theta[..., 0, None, None] / 100.0, theta[..., 1, None, None] / 12.0
        shape = torch.exp(-(((self.x - self.loads[:, None]) / 6.0) ** 2))
        return 20.0 * (1.0 + 0.5 * torch.sin(2.0 * a)) * shape + 5.0 * b**2 * self.x / 35.0


def test_plain_transform_for_a_model_without_elastic_structure(small_design) -> None:
    model = SmoothModel()
    sur = fit_surrogate(model, small_design, log_inputs=(), modulus=None,
                        relative_to_modulus=())
    assert sur.transform.modulus is None
    theta = _random_theta(30, seed=6)
    truth = model(theta)
    error = (sur(theta) - truth).abs().amax(dim=(-2, -1))
    assert float((error / truth.abs().amax(dim=(-2, -1))).max()) < 1e-3


def test_prediction_is_the_transformed_gp_posterior(fitted: Surrogate) -> None:
    theta = _random_theta(7, seed=8)
    latent_mean, latent_var = fitted.gp.predict(fitted.transform.inputs(theta))
    mean, var = fitted.predict(theta)
    expected_mean = fitted.transform.strains(theta, latent_mean).reshape(mean.shape)
    expected_var = fitted.transform.strain_variance(theta, latent_var).reshape(var.shape)
    torch.testing.assert_close(mean, expected_mean, rtol=1e-10, atol=1e-10)
    torch.testing.assert_close(var, expected_var, rtol=1e-10, atol=1e-14)

"""The upscaled-field form of Eq. (21) (kernel ``upscaled``): its operator against a direct
bilinear interpolation, its sparse density against scipy's dense Gaussian, refusals, and the
covariance of its predictive draws."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from scipy.ndimage import map_coordinates
from scipy.stats import multivariate_normal

from torchshm.kernels import get_kernel
from torchshm.likelihood import marginal, upscaled
from torchshm.likelihood.gaussian import log_likelihood

ELEMENT = 0.012  # m


def _field(nx: int = 5, ny: int = 4, factor: int = 3) -> np.ndarray:
    """`n x 2` points of a field upscaled ``factor`` times from `nx x ny` element centres."""
    step = ELEMENT / factor
    gx, gy = np.meshgrid(0.05 + step * np.arange((nx - 1) * factor + 1),
                         0.03 + step * np.arange((ny - 1) * factor + 1), indexing="ij")
    return np.column_stack([gx.ravel(), gy.ravel()])


def test_operator_is_the_bilinear_upscaling(rng: np.random.Generator) -> None:
    """``U e`` equals scipy's bilinear interpolation of the element values (muDIC's upscaling)."""
    values = rng.normal(size=(5, 4))
    u = upscaled.operator(_field(), ELEMENT)
    f = np.arange(13) / 3, np.arange(10) / 3
    gx, gy = np.meshgrid(*f, indexing="ij")
    expected = map_coordinates(values, [gx, gy], order=1).ravel()
    assert u.shape == (130, 20)
    np.testing.assert_allclose(u @ values.ravel(), expected, atol=1e-12)


def test_sparse_density_is_scipys_dense_gaussian(rng: np.random.Generator) -> None:
    """Woodbury through the elements = the dense N(eta, sa² U Uᵀ + diag) (1e-9 relative), with a
    hole in the field and sigma_m > 0 (a diagonal per load case)."""
    x = np.delete(_field(), [17, 18, 40], axis=0)
    n = x.shape[0]
    eta = rng.normal(300.0, 200.0, (3, 2, n))
    y = rng.normal(300.0, 200.0, (2, n))
    sa, sm, se = np.array([150.0, 300.0, 600.0]), 0.05, 20.0
    got = log_likelihood(torch.tensor(y), torch.tensor(eta), torch.tensor(x), "upscaled", torch.tensor(sa),
                         torch.full((3,), ELEMENT), sigma_m=sm, sigma_e=se)
    u = upscaled.operator(x, ELEMENT).toarray()
    for b in range(3):
        want = sum(multivariate_normal(eta[b, k], sa[b] ** 2 * u @ u.T + np.diag(se**2 + (sm * eta[b, k]) ** 2)
                                       ).logpdf(y[k]) for k in range(2))
        assert float(got[b]) == pytest.approx(want, rel=1e-9)


def test_auto_takes_the_sparse_form_and_refuses_what_it_cannot_do() -> None:
    kern = get_kernel("upscaled")
    assert marginal.choose_method(kern, 10**6, dim=2) == "upscaled"
    with pytest.raises(ValueError, match="sigma_e > 0"):
        marginal.choose_method(kern, 100, noise_positive=False, dim=2)
    with pytest.raises(ValueError, match="n x 2"):
        marginal.choose_method(kern, 100, dim=1)


def test_draws_have_the_covariance_of_the_density() -> None:
    """4000 draws: empirical covariance within 5 % (of the largest entry) of sa² U Uᵀ + se² I."""
    x = _field(3, 3)
    n = x.shape[0]
    gen = torch.Generator().manual_seed(3)
    eta = torch.zeros(4000, 1, n, dtype=torch.float64)
    draws = marginal.Eq21(eta, torch.tensor(x), get_kernel("upscaled"),
                          torch.full((4000,), 100.0), torch.full((4000,), ELEMENT), 0.0, 5.0).sample(gen)
    u = upscaled.operator(x, ELEMENT).toarray()
    want = 100.0**2 * u @ u.T + 25.0 * np.eye(n)
    got = np.cov(draws[:, 0].numpy().T)
    assert np.abs(got - want).max() < 0.05 * want.max()


def _dense_log_density(r: torch.Tensor, d: torch.Tensor, u: torch.Tensor, sa: torch.Tensor) -> torch.Tensor:
    """The oracle: N(0, sa² U Uᵀ + diag(d)) in torch, one Cholesky per load case, summed."""
    cov = sa**2 * u @ u.T + torch.diag_embed(d)
    return torch.distributions.MultivariateNormal(torch.zeros_like(r), covariance_matrix=cov).log_prob(r).sum()


def test_gradients_are_the_dense_gaussians(rng: np.random.Generator) -> None:
    """Autograd through the elimination = autograd through the dense Gaussian (1e-7 relative),
    with respect to the residuals, the diagonal (a different one per load case: sigma_m > 0)
    and sigma_a, on a field with a hole."""
    x = np.delete(_field(), [17, 18, 40], axis=0)
    n = x.shape[0]
    u = torch.as_tensor(upscaled.operator(x, ELEMENT).toarray())
    r0 = torch.as_tensor(rng.normal(0.0, 300.0, (2, n)))
    d0 = torch.as_tensor(20.0**2 + (0.05 * rng.normal(300.0, 200.0, (2, n))) ** 2)
    sa0 = torch.tensor(250.0, dtype=torch.float64)
    got_in = [t.clone().requires_grad_(True) for t in (r0, d0, sa0)]
    got = upscaled.log_density(got_in[0][None], got_in[1][None], torch.as_tensor(x), got_in[2][None],
                               torch.tensor([ELEMENT], dtype=torch.float64))[0]
    got.backward()
    want_in = [t.clone().requires_grad_(True) for t in (r0, d0, sa0)]
    want = _dense_log_density(want_in[0], want_in[1], u, want_in[2])
    want.backward()
    assert float(got.detach()) == pytest.approx(float(want.detach()), rel=1e-9)
    for g, w in zip(got_in, want_in):
        np.testing.assert_allclose(g.grad.numpy(), w.grad.numpy(), rtol=1e-7, atol=1e-7 * float(w.grad.abs().max()))


def test_gradient_in_eta_reaches_the_emulator(rng: np.random.Generator) -> None:
    """``log_likelihood``'s gradient in eta (what the emulator's error model and exploration
    read, ``EmulatedLogJoint.gradient``) is Σ⁻¹ (y - eta) with sigma_m = 0, not zero."""
    x = _field(4, 3)
    n = x.shape[0]
    u = upscaled.operator(x, ELEMENT).toarray()
    y, eta0 = rng.normal(0.0, 200.0, (1, n)), rng.normal(0.0, 200.0, (1, 1, n))
    eta = torch.tensor(eta0, requires_grad=True)
    value = log_likelihood(torch.tensor(y), eta, torch.tensor(x), "upscaled", torch.tensor([150.0]),
                           torch.tensor([ELEMENT]), sigma_m=0.0, sigma_e=10.0)
    (grad,) = torch.autograd.grad(value.sum(), eta)
    want = np.linalg.solve(150.0**2 * u @ u.T + 100.0 * np.eye(n), (y - eta0[0]).T).T
    np.testing.assert_allclose(grad[0].numpy(), want, rtol=1e-7, atol=1e-9)


def test_length_gradient_is_the_finite_difference(rng: np.random.Generator) -> None:
    """The bilinear weights follow ``length`` by autograd: the derivative equals a central
    difference (within one cell, where the grid does not change) to 1e-5 relative."""
    x = torch.as_tensor(_field(4, 4))
    r = torch.as_tensor(rng.normal(0.0, 100.0, (1, 1, x.shape[0])))
    d = torch.full_like(r, 25.0)
    sa = torch.tensor([80.0], dtype=torch.float64)
    ell = torch.tensor([ELEMENT * 1.01], dtype=torch.float64, requires_grad=True)
    (grad,) = torch.autograd.grad(upscaled.log_density(r, d, x, sa, ell)[0], ell)
    h = ELEMENT * 1e-6
    up = upscaled.log_density(r, d, x, sa, ell.detach() + h)[0]
    down = upscaled.log_density(r, d, x, sa, ell.detach() - h)[0]
    assert float(grad[0]) == pytest.approx(float(up - down) / (2 * h), rel=1e-5)


def test_a_fine_element_grid_takes_the_sparse_lu(rng: np.random.Generator) -> None:
    """An element side a tenth of the points' pitch (a grid of ~100 elements a point, above GRID_PER_POINT) goes
    through the sparse LU of the elements seen, and is still the dense Gaussian."""
    x = _field(3, 3)[::2]
    n = x.shape[0]
    ell = ELEMENT / 30.0
    u = upscaled.operator(x, ell).toarray()
    r = rng.normal(0.0, 50.0, (1, n))
    got = upscaled.log_density(torch.tensor(r[None]), torch.full((1, 1, n), 4.0), torch.tensor(x),
                               torch.tensor([30.0]), torch.tensor([ell]))
    want = multivariate_normal(np.zeros(n), 900.0 * u @ u.T + 4.0 * np.eye(n)).logpdf(r[0])
    assert float(got[0]) == pytest.approx(want, rel=1e-9)


def test_draws_are_sigma_a_u_z_in_the_generators_order_and_differentiable() -> None:
    """The draws are ``sigma_a U z`` with `z` the generator's next `L x N` normals of the elements
    seen (SciPy's sparse product's numbers, 1e-12) by torch's sparse product, and by a gather
    that carries gradients in sigma_a and length where length requires one."""
    x = np.delete(_field(4, 3), [5, 6], axis=0)
    u = upscaled.operator(x, ELEMENT)
    z = torch.randn(2, u.shape[1], generator=torch.Generator().manual_seed(5), dtype=torch.float64).numpy()
    sa = torch.tensor([40.0], dtype=torch.float64, requires_grad=True)
    ell = torch.tensor([ELEMENT], dtype=torch.float64, requires_grad=True)
    got = upscaled.sample(torch.tensor(x), sa, ell, 2, torch.Generator().manual_seed(5))
    np.testing.assert_allclose(got[0].detach().numpy(), 40.0 * (u @ z.T).T, rtol=1e-12, atol=1e-10)
    plain = upscaled.sample(torch.tensor(x), sa.detach(), ell.detach(), 2, torch.Generator().manual_seed(5))
    np.testing.assert_allclose(plain[0].numpy(), 40.0 * (u @ z.T).T, rtol=1e-12, atol=1e-10)  # the sparse product
    ga, gl = torch.autograd.grad(got.square().sum(), (sa, ell))
    assert float(ga) == pytest.approx(2.0 * float(got.detach().square().sum()) / 40.0, rel=1e-12)
    assert torch.isfinite(gl).all() and float(gl.abs()) > 0.0


@pytest.mark.parametrize("shape", ["one row", "one column", "scattered", "repeated"])
def test_points_off_a_full_grid_are_the_dense_gaussian(shape: str, rng: np.random.Generator) -> None:
    """A line of elements (corners clipped onto each other), points anywhere in the cells and
    repeated points: the elimination is still the dense Gaussian (1e-12 relative)."""
    x = {"one row": np.column_stack([np.arange(13) * ELEMENT / 3, np.zeros(13)]),
         "one column": np.column_stack([np.zeros(10), np.arange(10) * ELEMENT / 3]),
         "scattered": np.column_stack([rng.random(60) * 0.05, rng.random(60) * 0.04]),
         "repeated": np.repeat(np.column_stack([np.arange(7) * ELEMENT / 2, np.arange(7) * ELEMENT / 2 % 0.02]),
                               2, axis=0)}[shape]
    n = x.shape[0]
    u = upscaled.operator(x, ELEMENT).toarray()
    r, d = rng.normal(0.0, 30.0, (1, 2, n)), np.abs(rng.normal(20.0, 5.0, (1, 2, n))) + 1.0
    got = upscaled.log_density(torch.tensor(r), torch.tensor(d), torch.tensor(x), torch.tensor([25.0]),
                               torch.tensor([ELEMENT], dtype=torch.float64))
    want = sum(multivariate_normal(np.zeros(n), 625.0 * u @ u.T + np.diag(d[0, k])).logpdf(r[0, k]) for k in range(2))
    assert float(got[0]) == pytest.approx(want, rel=1e-12)

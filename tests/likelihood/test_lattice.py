"""The lattice form of Eq. (21) (kernel ``separable_exponential`` on a regular grid): the grid
read from the points, the nested-dissection order, the exact sparse density against the dense
Cholesky and scipy's Gaussian, the covariance of its draws, and when it is chosen."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from scipy.stats import multivariate_normal

import torchshm
from torchshm.kernels import get_kernel
from torchshm.likelihood import choice, lattice, marginal
from torchshm.likelihood.lattice_frontal import eliminate
from torchshm.likelihood.lattice_plan import plan
from torchshm.predictive import predictive_draws

NAME = "separable_exponential"
PX, PY = 0.003, 0.005  # m: non-square pitch


def _field(rng: np.random.Generator, nx: int = 40, ny: int = 30) -> np.ndarray:
    """`n x 2` points [m] of an `nx x ny` grid with a random 20 % mask and a rectangular hole."""
    ii, jj = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    ii, jj = ii.ravel(), jj.ravel()
    keep = (rng.random(ii.size) > 0.2) & ~((ii >= 10) & (ii < 22) & (jj >= 8) & (jj < 15))
    keep[[0, -1]] = True  # the bounding box is the whole grid
    return np.column_stack([0.1 + PX * ii[keep], -0.2 + PY * jj[keep]])


def test_lattice_reads_the_grid_of_the_points(rng: np.random.Generator) -> None:
    x = _field(rng)
    grid = lattice.lattice(torch.tensor(x))
    assert grid is not None and grid.shape == (40, 30)
    assert grid.pitch == pytest.approx((PX, PY), rel=1e-12)
    np.testing.assert_allclose(0.1 + PX * grid.ix, x[:, 0], atol=1e-12)
    np.testing.assert_allclose(-0.2 + PY * grid.iy, x[:, 1], atol=1e-12)
    assert lattice.lattice(x.astype(np.float32)) is not None  # rounding within 1e-4 pitch
    assert lattice.lattice(np.array([[0.0, 1.0], [0.5, 1.0], [1.5, 1.0]])).shape == (4, 1)  # a row
    assert lattice.lattice(x + rng.uniform(0.0, 1e-3 * PX, x.shape)) is None  # off the nodes
    assert lattice.lattice(np.array([[0.0, 0.0], [0.3, 0.0], [0.77, 0.0]])) is None  # no common pitch
    assert lattice.lattice(np.array([[0.0, 0.0], [0.3, 0.0], [1.0, 0.0]])).pitch[0] == pytest.approx(0.1)
    assert lattice.lattice(np.vstack([x, [[5.0, 5.0]]])) is None  # an outlier: far too many nodes
    assert lattice.lattice(x[:, :1]) is None


def _ar1(size: int, rho: float) -> np.ndarray:
    """Dense unit-variance AR(1) precision (numpy, the test's own)."""
    if size == 1:
        return np.ones((1, 1))
    q = np.diag(np.full(size, 1.0 + rho**2))
    q[0, 0] = q[-1, -1] = 1.0
    i = np.arange(size - 1)
    q[i, i + 1] = q[i + 1, i] = -rho
    return q / (1.0 - rho**2)


@pytest.mark.parametrize("shape", [(5, 3), (1, 30), (33, 2), (50, 31)])
def test_elimination_is_numpys_determinant_and_solve(rng: np.random.Generator, shape: tuple[int, int]) -> None:
    """The multifrontal pass over the dissection (every node eliminated once, children first)
    gives log det M and bᵀ M⁻¹ b of M = Qx ⊗ Qy / sa² + diag(w) to 1e-12."""
    nx, ny = shape
    assert sum(len(g.origin) * g.e for g in plan(nx, ny)) == nx * ny
    rho_x, rho_y, sa = 0.7, 0.2, 2.0
    w, b = rng.uniform(1.0, 2.0, nx * ny), rng.normal(size=(nx * ny, 2))
    m = np.kron(_ar1(nx, rho_x), _ar1(ny, rho_y)) / sa**2 + np.diag(w)
    factors = [torch.tensor(v) for v in (rho_x, 1 - rho_x**2, rho_y, 1 - rho_y**2)]
    log_det, quad = eliminate(shape, tuple(factors), torch.tensor(1 / sa**2), torch.tensor(w), torch.tensor(b))
    assert float(log_det) == pytest.approx(np.linalg.slogdet(m)[1], rel=1e-12)
    np.testing.assert_allclose(quad.numpy(), np.einsum("ik,ik->k", b, np.linalg.solve(m, b)), rtol=1e-12)


@pytest.mark.parametrize("sigma_m", [0.0, 0.05])
def test_density_is_the_dense_gaussian(rng: np.random.Generator, sigma_m: float) -> None:
    """~900 points with holes, 3 load cases, lengths from 0.3 pitch to 3 x the field (and
    sigma_a = 0), heteroscedastic noise (sigma_m > 0, eta varying): equal to the dense Cholesky
    and to scipy's multivariate normal to 1e-8 relative."""
    x = torch.tensor(_field(rng))
    n = x.shape[0]
    extent = 40 * PX
    ell = torch.tensor([0.3 * PX, 2 * PX, 0.3 * extent, extent, 3 * extent, 0.01])
    sa = torch.tensor([80.0, 300.0, 150.0, 300.0, 40.0, 0.0])  # the last: no discrepancy
    eta = torch.tensor(rng.normal(300.0, 200.0, (6, 3, n)))
    y = torch.tensor(rng.normal(300.0, 200.0, (3, n)))
    kern = get_kernel(NAME)
    sparse = marginal.Eq21(eta, x, kern, sa, ell, sigma_m, 20.0)
    assert sparse.method == "lattice"
    dense = marginal.Eq21(eta, x, kern, sa, ell, sigma_m, 20.0, method="dense").log_prob(y)
    got = sparse.log_prob(y)
    torch.testing.assert_close(got, dense, rtol=1e-8, atol=0)
    for b in (0, 4):
        cov = kern(x, sigma_a=sa[b], length=ell[b]).numpy()
        want = sum(multivariate_normal(eta[b, k].numpy(), cov + np.diag(20.0**2 + (sigma_m * eta[b, k].numpy()) ** 2)
                                       ).logpdf(y[k].numpy()) for k in range(3))
        assert float(got[b]) == pytest.approx(want, rel=1e-8)


def test_log_likelihood_of_a_field_is_the_dense_one(rng: np.random.Generator) -> None:
    """The public ``log_likelihood`` with ``kernel="separable_exponential"`` on a small field
    (several parameter vectors, inferred sigma_m): the lattice form, equal to the dense one."""
    x = torch.tensor(_field(rng, 15, 12))
    n = x.shape[0]
    y = torch.tensor(rng.normal(100.0, 50.0, (2, n)))
    eta = torch.tensor(rng.normal(100.0, 50.0, (3, 2, n)))
    sa, ell, sm = torch.tensor([30.0, 60.0, 10.0]), torch.tensor([0.01, 0.05, 0.2]), torch.tensor([0.0, 0.02, 0.1])
    auto = torchshm.log_likelihood(y, eta, x, NAME, sa, ell, sigma_m=sm, sigma_e=5.0)
    dense = torchshm.log_likelihood(y, eta, x, NAME, sa, ell, sigma_m=sm, sigma_e=5.0, method="dense")
    forced = torchshm.log_likelihood(y, eta, x, NAME, sa, ell, sigma_m=sm, sigma_e=5.0, method="lattice")
    torch.testing.assert_close(auto, dense, rtol=1e-9, atol=0)
    torch.testing.assert_close(forced, auto, rtol=0, atol=0)


def test_gradients_are_the_dense_ones(rng: np.random.Generator) -> None:
    """Autograd through the elimination: d/d(eta, sigma_a, length, sigma_m) of the log
    density equal the dense path's to 1e-7 relative."""
    x = torch.tensor(_field(rng, 12, 9))
    n = x.shape[0]
    y, eta0 = torch.tensor(rng.normal(100.0, 50.0, (2, n))), torch.tensor(rng.normal(100.0, 50.0, (2, 2, n)))
    grads = []
    for method in ("lattice", "dense"):
        eta = eta0.clone().requires_grad_(True)
        sa, ell, sm = (torch.tensor(v, requires_grad=True) for v in ([30.0, 60.0], [0.01, 0.05], [0.02, 0.05]))
        torchshm.log_likelihood(y, eta, x, NAME, sa, ell, sigma_m=sm, sigma_e=5.0, method=method).sum().backward()
        grads.append([t.grad for t in (eta, sa, ell, sm)])
    for got, want in zip(*grads):
        torch.testing.assert_close(got, want, rtol=1e-7, atol=1e-9)


def test_readings_without_noise_are_exact(rng: np.random.Generator) -> None:
    """sigma_e = 0: with sigma_m = 0 every reading fixes the field at its node, with sigma_m > 0
    only those where eta is 0; the lattice form (chosen by "auto") equals the dense Cholesky
    and scipy's multivariate normal to 1e-7 relative, and its gradients the dense path's."""
    x = torch.tensor(_field(rng, 14, 11))
    n = x.shape[0]
    kern = get_kernel(NAME)
    y = torch.tensor(rng.normal(100.0, 50.0, (2, n)))
    eta = torch.tensor(rng.normal(100.0, 50.0, (3, 2, n)))
    eta[1, :, rng.random(n) < 0.4] = 0.0  # exact readings among noisy ones (sigma_m > 0)
    sa, ell = torch.tensor([30.0, 60.0, 10.0]), torch.tensor([0.005, 0.05, 0.2])
    assert choice.choose_method(kern, n, "auto", noise_positive=False, dim=2, x=x) == "lattice"
    for sm in (0.0, 0.05):
        got = torchshm.log_likelihood(y, eta, x, NAME, sa, ell, sigma_m=sm, sigma_e=0.0)
        dense = torchshm.log_likelihood(y, eta, x, NAME, sa, ell, sigma_m=sm, sigma_e=0.0, method="dense")
        torch.testing.assert_close(got, dense, rtol=1e-7, atol=0)
        for b in (0, 1):
            cov = kern(x, sigma_a=sa[b], length=ell[b]).numpy()
            want = sum(multivariate_normal(eta[b, k].numpy(), cov + np.diag((sm * eta[b, k].numpy()) ** 2)
                                           ).logpdf(y[k].numpy()) for k in range(2))
            assert float(got[b]) == pytest.approx(want, rel=1e-7)
    grads = []
    for method in ("lattice", "dense"):
        e = eta[0].clone().requires_grad_(True)
        s, l = torch.tensor(30.0, requires_grad=True), torch.tensor(0.02, requires_grad=True)
        torchshm.log_likelihood(y, e, x, NAME, s, l, sigma_m=0.0, sigma_e=0.0, method=method).sum().backward()
        grads.append([t.grad for t in (e, s, l)])
    for got, want in zip(*grads):
        torch.testing.assert_close(got, want, rtol=1e-6, atol=1e-8)


def test_two_readings_without_noise_at_one_node_are_refused(rng: np.random.Generator) -> None:
    """A repeated point without noise makes the density singular: "auto" keeps the dense form
    for it, ``method='lattice'`` and the lattice density refuse it in one line."""
    x = torch.tensor(_field(rng, 8, 6))
    x = torch.cat([x, x[:1]])
    n = x.shape[0]
    kern = get_kernel(NAME)
    assert choice.choose_method(kern, n, "auto", noise_positive=True, dim=2, x=x) == "lattice"
    assert choice.choose_method(kern, n, "auto", noise_positive=False, dim=2, x=x) == "dense"
    with pytest.raises(ValueError, match="points repeat"):
        choice.choose_method(kern, n, "lattice", noise_positive=False, dim=2, x=x)
    with pytest.raises(ValueError, match="two readings without noise"):
        lattice.log_density(torch.ones(1, 1, n), torch.zeros(1, 1, n), x, torch.tensor([1.0]), torch.tensor([0.1]))


def test_draws_have_the_kernels_covariance() -> None:
    """20,000 draws (fixed seed) on a 6 x 5 grid with a hole: empirical covariance within 0.04
    (of the largest entry, 3.5 standard errors) of sa² exp(-|dx|/l - |dy|/l) + se² I."""
    ii, jj = np.meshgrid(np.arange(6), np.arange(5), indexing="ij")
    keep = ~((ii.ravel() == 2) & (jj.ravel() >= 1) & (jj.ravel() <= 3))
    x = torch.tensor(np.column_stack([PX * ii.ravel(), PY * jj.ravel()])[keep])
    n, draws = x.shape[0], 20_000
    kern = get_kernel(NAME)
    gaussian = marginal.Eq21(torch.zeros(1, draws, n), x, kern, torch.tensor([10.0]), torch.tensor([0.01]), 0.0, 2.0)
    assert gaussian.method == "lattice"
    got = np.cov(gaussian.sample(torch.Generator().manual_seed(5))[0].numpy().T)
    want = kern(x, sigma_a=10.0, length=0.01).numpy() + 4.0 * np.eye(n)
    assert np.abs(got - want).max() < 0.04 * want.max()


def test_choice_lattice_on_a_grid_dense_or_fullscale_elsewhere(rng: np.random.Generator,
                                                             monkeypatch: pytest.MonkeyPatch) -> None:
    kern = get_kernel(NAME)
    grid = torch.tensor(_field(rng))
    off = torch.tensor(rng.uniform(0.0, 1.0, (6000, 2)))
    n = grid.shape[0]
    assert choice.choose_method(kern, n, "auto", dim=2, x=grid) == "lattice"
    assert choice.choose_method(kern, n, "lattice", dim=2, x=grid) == "lattice"
    assert choice.choose_method(kern, n, "dense", dim=2, x=grid) == "dense"
    assert choice.choose_method(kern, n, "auto", noise_positive=False, dim=2, x=grid) == "lattice"
    assert choice.choose_method(kern, 6000, "auto", dim=2, x=off) == "dense"  # exact while it fits
    for method in ("vecchia", "fullscale"):
        assert choice.choose_method(kern, n, method, dim=2, x=grid) == method
    with pytest.raises(ValueError, match="not on one regular grid|these points are not"):
        choice.choose_method(kern, 6000, "lattice", dim=2, x=off)
    with pytest.raises(ValueError, match="kernel 'matern32' has none"):
        choice.choose_method(get_kernel("matern32"), n, "lattice", dim=2, x=grid)
    monkeypatch.setattr(choice, "_physical_memory", lambda: 2**30)  # a 1 GiB machine
    with pytest.raises(ValueError, match=r"^10000 points .*get the exact sparse form \(method='lattice'\)"):
        choice.choose_method(kern, 10_000, "dense", dim=2, x=None)
    off = torch.tensor(rng.uniform(0.0, 1.0, (10_000, 2)))
    assert choice.choose_method(kern, 10_000, "auto", dim=2, x=off) == "fullscale"  # too large for dense


@pytest.mark.parametrize("form", ["vecchia", "fullscale"])
def test_the_neighbour_forms_take_the_l1_distance(rng: np.random.Generator, form: str) -> None:
    """Off a grid the Vecchia and full-scale forms see the kernel in its L1 distance: with every
    earlier point in each conditioning set they are exact, equal to the dense Cholesky to 1e-9
    relative (80 random points, heteroscedastic noise)."""
    from torchshm.likelihood import fullscale, vecchia

    x = torch.tensor(rng.uniform(0.0, 0.1, (80, 2)))
    kern = get_kernel(NAME)
    sa, ell = torch.tensor([3.0, 1.0]), torch.tensor([0.01, 0.05])
    resid = torch.tensor(rng.normal(0.0, 3.0, (2, 2, 80)))
    noise = torch.tensor(rng.uniform(0.05, 0.5, (2, 2, 80)))
    want = torch.stack([sum(torch.distributions.MultivariateNormal(
        torch.zeros(80, dtype=torch.float64), kern(x, sigma_a=sa[b], length=ell[b]) + torch.diag(noise[b, k])
    ).log_prob(resid[b, k]) for k in range(2)) for b in range(2)])
    if form == "vecchia":
        got = vecchia.log_density(resid, noise, x, kern, sa, ell, m=79)
    else:
        got = fullscale.log_density(resid, noise, x, kern, sa, ell, m=79, rank=8)
    torch.testing.assert_close(got, want, rtol=1e-9, atol=0)


def test_draws_of_a_large_grid_without_noise_take_the_lattice() -> None:
    """120,000 grid points with sigma_e = 0 (a dense covariance: 230 GB, refused): the lattice
    draws, whose mean square is sigma_a² (within 5 %; its sd is about 2 %: ~4,500 patches of
    the length's size)."""
    ii, jj = np.meshgrid(np.arange(400), np.arange(300), indexing="ij")
    x = torch.tensor(np.column_stack([PX * ii.ravel(), PY * jj.ravel()]))
    eta = torch.zeros(1, 1, x.shape[0])
    got = predictive_draws(eta, x, NAME, torch.tensor([3.0]), torch.tensor([0.01]), 0.0, 0.0,
                           torch.Generator().manual_seed(2))
    assert got.shape == (1, 1, 120_000)
    assert float(got.square().mean()) == pytest.approx(9.0, rel=0.05)


class _Field:
    """A linear model of an `n x 2` field: ``a(x, y, load) 30 / E_c + b(x, y, load) log10_K_r`` [µε]."""

    names = ("E_c", "log10_K_r")

    def __init__(self, x: np.ndarray) -> None:
        self.x = torch.tensor(x)
        self.loads = torch.tensor([10.0, 20.0])
        self.a = 40.0 * torch.sin(60.0 * self.x[None, :, 0] + self.loads[:, None])
        self.b = torch.cos(90.0 * self.x[None, :, 1] - self.loads[:, None])

    def __call__(self, theta_p: torch.Tensor) -> torch.Tensor:
        theta_p = torch.as_tensor(theta_p, dtype=torch.float64)
        return self.a * (30.0 / theta_p[..., 0, None, None]) + self.b * theta_p[..., 1, None, None]

    @staticmethod
    def default_priors() -> dict:
        from torchshm.casestudy import paper_priors

        return paper_priors()


@pytest.mark.parametrize("sigma_e, sigma_m", [(0.5, 0.05), (0.0, 0.0)])
def test_a_problem_on_a_field_evaluates_as_the_dense_path(rng: np.random.Generator, sigma_e: float,
                                                          sigma_m: float) -> None:
    """``torchshm.Problem`` with ``kernel="separable_exponential"`` on a 15 x 12 field with holes
    (the lattice form; with sigma_e = sigma_m = 0 every reading exact) equals the same problem
    with the kernel forced dense, to 1e-9 (1e-7 without noise)."""
    from torchshm.kernels.separable import SeparableExponential

    class DenseOnly(SeparableExponential):  # the same kernel without its sparse form
        form = None

    x = _field(rng, 15, 12)
    model = _Field(x)
    y = model(torch.tensor([33.0, 11.5])).numpy() + rng.normal(0.0, 0.5, (2, len(x)))
    meas = torchshm.Measurements(x, y, [10.0, 20.0], sigma_e=sigma_e)
    theta = np.array([[33.0, 11.5, 0.9, 0.02], [30.0, 11.0, 2.0, 0.1]])
    sparse = torchshm.Problem(model, meas, kernel="separable_exponential", sigma_m=sigma_m).log_likelihood(theta)
    dense = torchshm.Problem(model, meas, kernel=DenseOnly(), sigma_m=sigma_m).log_likelihood(theta)
    np.testing.assert_allclose(sparse, dense, rtol=1e-9 if sigma_e else 1e-7)


def test_the_grid_of_the_same_tensor_is_read_once_and_again_after_a_change() -> None:
    """One evaluation asks for the grid of its points several times: the same, unchanged
    tensor gets the grid read the first time; a change in place (its version) reads it again."""
    g = np.linspace(0.0, 1.0, 5)
    x = torch.tensor(np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2))
    first = lattice.lattice(x)
    assert lattice.lattice(x) is first
    assert lattice.lattice(x.clone()) is not first and lattice.lattice(x.clone()).shape == first.shape
    x[:, 0] *= 2.0
    again = lattice.lattice(x)
    assert again is not first and again.pitch[0] == pytest.approx(2.0 * first.pitch[0])

"""Every kernel of Table 6 runs the same checks (shared mixin), plus kernel-specific ones."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from torchshm.kernels import KERNELS, Kernel, get_kernel


class KernelChecks:
    """Checks every kernel must pass. A subclass sets ``name`` and the paper's ``formula``."""

    name: str

    @staticmethod
    def formula(d: np.ndarray, s: float, ell: float) -> np.ndarray:
        raise NotImplementedError

    @property
    def kernel(self) -> Kernel:
        return get_kernel(self.name)

    def test_registered(self) -> None:
        assert self.name in KERNELS
        assert isinstance(self.kernel, Kernel) and self.kernel.name == self.name

    def test_matches_table6_formula(self, rng: np.random.Generator) -> None:
        d = np.concatenate([[0.0], rng.uniform(0.0, 6.0, 200)])
        for s, ell in [(0.9, 2.0), (3.0, 0.3), (0.2, 7.5)]:
            k = self.kernel(torch.as_tensor(d), torch.zeros(1), sigma_a=s, length=ell)
            np.testing.assert_allclose(k[:, 0].numpy(), self.formula(d, s, ell), rtol=1e-13, atol=0)

    def test_distance_is_symmetric_in_sign(self, rng: np.random.Generator) -> None:
        x = torch.as_tensor(rng.uniform(-3, 3, 30))
        k_plus = self.kernel(x, torch.zeros(1), sigma_a=1.3, length=0.8)
        k_minus = self.kernel(-x, torch.zeros(1), sigma_a=1.3, length=0.8)
        torch.testing.assert_close(k_plus, k_minus, rtol=0, atol=0)

    def test_symmetric_positive_definite(self, rng: np.random.Generator) -> None:
        x = torch.as_tensor(np.cumsum(rng.uniform(0.3, 1.0, 40)))
        k = self.kernel(x, sigma_a=1.7, length=0.9)
        assert torch.equal(k, k.mT)
        assert torch.linalg.eigvalsh(k).min() > 0
        assert int(torch.linalg.cholesky_ex(k).info) == 0

    def test_batch_equals_loop(self, rng: np.random.Generator) -> None:
        x = torch.as_tensor(np.sort(rng.uniform(0, 10, 25)))
        sigma_a = torch.as_tensor(rng.uniform(0.1, 3, (3, 2)))
        length = torch.as_tensor(rng.uniform(0.1, 5, (3, 2)))
        k = self.kernel(x, sigma_a=sigma_a, length=length)
        assert k.shape == (3, 2, 25, 25)
        for i in range(3):
            for j in range(2):
                one = self.kernel(x, sigma_a=float(sigma_a[i, j]), length=float(length[i, j]))
                torch.testing.assert_close(k[i, j], one, rtol=0, atol=0)

    def test_broadcasts_scale_against_length(self) -> None:
        x = torch.linspace(0, 2, 7)
        k = self.kernel(x, sigma_a=torch.tensor([0.5, 1.0, 2.0]), length=torch.tensor(1.5))
        assert k.shape == (3, 7, 7)
        torch.testing.assert_close(k[2], 16.0 * k[0])

    def test_diag_equals_full_diagonal(self, rng: np.random.Generator) -> None:
        x = torch.as_tensor(rng.uniform(0, 10, 12))
        sigma_a = torch.tensor([0.3, 2.0])
        full = self.kernel(x, sigma_a=sigma_a, length=torch.tensor([0.5, 4.0]))
        torch.testing.assert_close(
            self.kernel.diag(x, sigma_a=sigma_a), full.diagonal(dim1=-2, dim2=-1)
        )

    def test_rectangular_cross_covariance(self, rng: np.random.Generator) -> None:
        x1, x2 = rng.uniform(0, 5, 6), rng.uniform(0, 5, 4)
        k = self.kernel(torch.as_tensor(x1), torch.as_tensor(x2), sigma_a=1.1, length=0.7)
        assert k.shape == (6, 4)
        d = np.abs(x1[:, None] - x2[None, :])
        np.testing.assert_allclose(k.numpy(), self.formula(d, 1.1, 0.7), rtol=1e-13, atol=0)

    @pytest.mark.parametrize("ell", [0.0, 1e-300, 1e-12, 1e-3])
    @pytest.mark.parametrize("s", [0.0, 1e-8, 2.0])
    def test_safe_at_zero_length_and_scale(self, ell: float, s: float) -> None:
        x = torch.linspace(35.0, 36.0, 11)
        sigma_a = torch.tensor(s, requires_grad=True)
        length = torch.tensor(ell, requires_grad=True)
        k = self.kernel(x, sigma_a=sigma_a, length=length)
        assert torch.isfinite(k).all()
        torch.testing.assert_close(k.diagonal(), torch.full((11,), s * s), rtol=0, atol=0)
        if self.kernel.has_length and ell <= 1e-3:  # 0.1 m apart: no correlation left
            off = k.detach().clone().fill_diagonal_(0.0)
            assert float(off.abs().max()) < 1e-30
        (self.kernel(x, sigma_a=sigma_a, length=length) * torch.rand(11, 11)).sum().backward()
        assert torch.isfinite(sigma_a.grad)
        assert length.grad is None or torch.isfinite(length.grad)


class TestIndependent(KernelChecks):
    name = "independent"

    @staticmethod
    def formula(d: np.ndarray, s: float, ell: float) -> np.ndarray:
        return s**2 * (d == 0)

    def test_equals_scaled_identity(self, rng: np.random.Generator) -> None:
        x = torch.as_tensor(np.sort(rng.uniform(0, 10, 30)))
        k = self.kernel(x, sigma_a=torch.tensor([0.5, 1.5]))
        torch.testing.assert_close(
            k, torch.tensor([0.25, 2.25])[:, None, None] * torch.eye(30), rtol=0, atol=0
        )

    def test_needs_no_length(self) -> None:
        assert not self.kernel.has_length and self.kernel.is_diagonal
        k = self.kernel(torch.arange(4.0), sigma_a=2.0, length=None)
        torch.testing.assert_close(k, 4.0 * torch.eye(4))


class TestExponential(KernelChecks):
    name = "exponential"

    @staticmethod
    def formula(d: np.ndarray, s: float, ell: float) -> np.ndarray:
        return s**2 * np.exp(-d / ell)


class TestMatern32(KernelChecks):
    name = "matern32"

    @staticmethod
    def formula(d: np.ndarray, s: float, ell: float) -> np.ndarray:
        return s**2 * (1 + np.sqrt(3) * d / ell) * np.exp(-np.sqrt(3) * d / ell)


class TestMatern52(KernelChecks):
    name = "matern52"

    @staticmethod
    def formula(d: np.ndarray, s: float, ell: float) -> np.ndarray:
        return (
            s**2
            * (1 + np.sqrt(5) * d / ell + 5 * d**2 / (3 * ell**2))
            * np.exp(-np.sqrt(5) * d / ell)
        )


class TestSquaredExponential(KernelChecks):
    name = "squared_exponential"

    @staticmethod
    def formula(d: np.ndarray, s: float, ell: float) -> np.ndarray:
        return s**2 * np.exp(-((d / ell) ** 2))

    def test_has_no_factor_one_half(self) -> None:
        k = self.kernel(torch.tensor([0.0, 1.0]), sigma_a=1.0, length=1.0)
        assert float(k[0, 1]) == pytest.approx(np.exp(-1.0), rel=1e-15)


def test_every_kernel_has_a_checked_class() -> None:
    checked = {cls.name for cls in KernelChecks.__subclasses__()}
    assert checked == set(KERNELS)
    assert KERNELS == ("independent", "exponential", "matern32", "matern52", "squared_exponential")


def test_unknown_kernel_is_named_with_the_valid_ones() -> None:
    with pytest.raises(
        ValueError, match=r"unknown kernel 'matern12'.*independent.*squared_exponential"
    ):
        get_kernel("matern12")


def test_a_length_kernel_refuses_a_missing_length() -> None:
    with pytest.raises(ValueError, match="length"):
        get_kernel("matern32")(torch.arange(3.0), sigma_a=1.0, length=None)


def test_public_names() -> None:
    import torchshm

    assert torchshm.KERNELS == KERNELS


def test_squared_exponential_spectral_density_transforms_to_its_correlation() -> None:
    """∫ S(ω) cos(ω d) dω / 2π = exp(-(d/l)²) (trapezoid over ±40/l, 1e-10)."""
    kern = get_kernel("squared_exponential")
    length = torch.tensor(0.7, dtype=torch.float64)
    omega = torch.linspace(-40.0 / 0.7, 40.0 / 0.7, 200_001, dtype=torch.float64)
    d = torch.tensor([0.0, 0.3, 0.7, 1.5], dtype=torch.float64)
    density = kern.spectral_density(omega, length)
    values = torch.trapezoid(density * torch.cos(omega * d[:, None]), omega) / (2 * torch.pi)
    torch.testing.assert_close(values, kern.correlation(d, length), rtol=0, atol=1e-10)
    assert kern.gaussian_spread == pytest.approx(2**-0.5)
    assert get_kernel("matern32").gaussian_spread is None

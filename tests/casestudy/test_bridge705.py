"""bridge705(): shapes, exact spring limits, batching, gradients and the physics targets."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch

import torchshm
from torchshm.casestudy import Bridge705, Bridge705Config, T1_POSITIONS, bridge705
from torchshm.casestudy.model import FORMULATION, bridge_mesh, load_matrix
from torchshm.casestudy.frame import solve
from torchshm.casestudy.geometry import PierBase

TRUTH = torch.tensor([35.0, 11.5])


@pytest.fixture(scope="module")
def model() -> Bridge705:
    return bridge705()


def direct(config: Bridge705Config, E_c: float, pier_base: PierBase, K_r: float = 0.0) -> torch.Tensor:
    """Strains [µε] `L x n` from a frame assembled and solved directly at E_c, without Woodbury."""
    mesh = bridge_mesh(config, E=1000.0 * E_c, pier_base=pier_base, K_r=K_r)
    U = solve(mesh.frame, load_matrix(mesh, config))
    return 1e6 * (mesh.strain_operator(config.sensor_x(), config.deck.c_b) @ U).T


@pytest.fixture(scope="module")
def bases(model: Bridge705) -> dict[str, torch.Tensor]:
    """Direct solves at E_c = 35 GPa: hinged and fixed pier bases, springs of 10^11.5 N·mm/rad."""
    return {
        "hinged": direct(model.config, 35.0, "hinged"),
        "fixed": direct(model.config, 35.0, "fixed"),
        "11.5": direct(model.config, 35.0, "spring", K_r=10.0**11.5),
    }


def rel_err(a: torch.Tensor, b: torch.Tensor) -> float:
    return float((a - b).abs().max() / b.abs().max())


def test_public_attributes(model: Bridge705) -> None:
    assert torchshm.bridge705 is bridge705 and torchshm.Bridge705 is Bridge705
    assert model.names == ("E_c", "log10_K_r")
    assert model.x.dtype == torch.float64 and model.x.shape == (351,)
    assert float(model.x[0]) == pytest.approx(35.0) and float(model.x[-1]) == pytest.approx(70.0)
    np.testing.assert_allclose(np.diff(model.x.numpy()), 0.1, atol=1e-9)
    assert model.loads.dtype == torch.float64
    np.testing.assert_array_equal(model.loads.numpy(), T1_POSITIONS)
    out = model(TRUTH)
    assert out.shape == (12, 351) and out.dtype == torch.float64
    batch = torch.rand(3, 4, 2) * torch.tensor([40.0, 12.0]) + torch.tensor([20.0, 0.0])
    assert model(batch).shape == (3, 4, 12, 351)
    assert model(np.array([35.0, 11.5])).shape == (12, 351)


def test_identity_is_stable_and_tracks_the_configuration(model: Bridge705) -> None:
    assert model.identity == bridge705().identity
    assert model.identity == f"{model.config.identity()}-{FORMULATION}"
    assert model.identity.startswith("bridge705-")
    assert dataclasses.replace(Bridge705Config(), pier_height=5.0).identity() != model.config.identity()


def test_bad_parameter_shape_is_rejected(model: Bridge705) -> None:
    with pytest.raises(ValueError, match="2 parameters"):
        model(torch.tensor([35.0, 11.5, 1.0]))


def test_spring_limits_equal_hinged_and_fixed_bases(model: Bridge705, bases: dict[str, torch.Tensor]) -> None:
    hinged, fixed = bases["hinged"], bases["fixed"]
    assert rel_err(model(torch.tensor([35.0, 0.0])), hinged) < 1e-6
    assert rel_err(model(torch.tensor([35.0, -400.0])), hinged) < 1e-8
    assert rel_err(model(torch.tensor([35.0, 20.0])), fixed) < 1e-6
    assert rel_err(model(torch.tensor([35.0, 400.0])), fixed) < 1e-8
    assert rel_err(hinged, fixed) > 1e-3  # the limits differ: the test can fail


def test_woodbury_equals_a_direct_spring_solve(model: Bridge705, bases: dict[str, torch.Tensor]) -> None:
    assert rel_err(model(TRUTH), bases["11.5"]) < 1e-8


def test_batch_equals_loop(model: Bridge705) -> None:
    generator = torch.Generator().manual_seed(0)
    theta = torch.rand(4, 5, 2, generator=generator) * torch.tensor([90.0, 12.0]) + torch.tensor([10.0, 0.0])
    batch = model(theta)
    loop = torch.stack([torch.stack([model(theta[i, j]) for j in range(5)]) for i in range(4)])
    assert float((batch - loop).abs().max()) <= 1e-10


@pytest.mark.parametrize("point", [(35.0, 11.5), (20.0, 10.0), (60.0, 12.0)])
def test_gradient_matches_central_differences(model: Bridge705, point: tuple[float, float]) -> None:
    weights = torch.randn(12, 351, generator=torch.Generator().manual_seed(1))
    theta = torch.tensor(point, requires_grad=True)
    (grad,) = torch.autograd.grad((weights * model(theta)).sum(), theta)
    steps = (1e-4 * point[0], 1e-4)
    for k, h in enumerate(steps):
        up, down = torch.tensor(point), torch.tensor(point)
        up[k] += h
        down[k] -= h
        fd = float(((weights * model(up)).sum() - (weights * model(down)).sum()) / (2 * h))
        assert float(grad[k]) == pytest.approx(fd, rel=1e-5)


def test_every_axle_strain_of_the_jacobian_is_finite(model: Bridge705) -> None:
    theta = torch.tensor([[35.0, -50.0], [35.0, 50.0]], requires_grad=True)
    (grad,) = torch.autograd.grad(model(theta).sum(), theta)
    assert torch.isfinite(grad).all()


def test_peak_strain_and_identifiability(model: Bridge705) -> None:
    truth = model(TRUTH)
    assert 20.0 <= float(truth.abs().max()) <= 60.0
    change = (model(torch.tensor([35.0, 12.0])) - model(torch.tensor([35.0, 9.0]))).abs().max()
    assert float(change) >= 1.0


def test_strain_scales_with_the_inverse_modulus_at_fixed_spring_ratio(model: Bridge705) -> None:
    # s depends on E and κ = K_r / E only: s(2E, 2K_r) = s(E, K_r) / 2
    doubled = model(torch.tensor([70.0, 11.5 + np.log10(2.0)]))
    torch.testing.assert_close(doubled, model(TRUTH) / 2, rtol=1e-10, atol=1e-12)
    ratio = model(torch.tensor([20.0, 11.5])).abs().max() / model(torch.tensor([60.0, 11.5])).abs().max()
    assert 2.9 < float(ratio) < 3.1


def test_sagging_under_the_truck_is_tension(model: Bridge705) -> None:
    strains = model(TRUTH)
    at_axle = strains[6, int(np.argmin(np.abs(model.x.numpy() - 50.0)))]  # load 55.1: axles in span 4
    assert float(at_axle) > 20.0

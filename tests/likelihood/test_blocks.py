"""Likelihood blocks by (line, load case) with masked readings, against an independent dense Gaussian."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from scipy import linalg, stats

from torchshm.likelihood import log_likelihood
from torchshm.likelihood.blocks import blocks_log_likelihood, full_mask, make_blocks
from torchshm.likelihood.marginal import choose_method
from torchshm.kernels import get_kernel

SLICES = {"bottom": slice(0, 30), "top": slice(30, 55)}
NOISE = {"bottom": 0.1, "top": 0.3}


def matern32(d: np.ndarray, s: float, ell: float) -> np.ndarray:
    return s**2 * (1 + np.sqrt(3) * d / ell) * np.exp(-np.sqrt(3) * d / ell)


@pytest.fixture
def campaign(rng: np.random.Generator) -> dict:
    x = np.concatenate([np.sort(rng.uniform(0.0, 5.0, 30)), np.sort(rng.uniform(0.0, 4.0, 25))])
    mask = rng.random((3, 55)) > 0.15
    mask[1] = True  # one load case without dropout
    eta = rng.normal(0.0, 20.0, (2, 3, 55))
    y = eta[0] + rng.normal(0.0, 1.0, (3, 55))
    return {"x": x, "mask": mask, "eta": eta, "y": np.where(mask, y, np.nan)}


def scipy_deleted(c: dict, b: int, s: list[float], ell: list[float], sigma_m: float) -> float:
    """The readings deleted by hand: one block-diagonal covariance over the valid ones, scipy."""
    covs, resid = [], []
    for l in range(c["y"].shape[0]):
        for g, (label, part) in enumerate(SLICES.items()):
            idx = np.arange(part.start, part.stop)[c["mask"][l, part]]
            x, eta = c["x"][idx], c["eta"][b, l, idx]
            k = matern32(np.abs(x[:, None] - x[None, :]), s[g], ell[g])
            covs.append(k + np.diag(sigma_m**2 * eta**2 + NOISE[label] ** 2))
            resid.append(c["y"][l, idx] - eta)
    r = np.concatenate(resid)
    return float(stats.multivariate_normal(np.zeros(r.size), linalg.block_diag(*covs)).logpdf(r))


@pytest.mark.parametrize("method", ["dense", "state_space"])
@pytest.mark.parametrize("per_line", [False, True])
def test_masked_blocks_equal_deleted_readings(campaign: dict, method: str, per_line: bool) -> None:
    groups = {"bottom": 0, "top": 1} if per_line else None
    blocks = make_blocks(campaign["x"], campaign["mask"], SLICES, NOISE, groups)
    s = torch.tensor([[1.5, 0.7], [0.4, 2.0]])[:, : 2 if per_line else 1]
    ell = torch.tensor([[0.8, 2.0], [0.3, 1.1]])[:, : 2 if per_line else 1]
    got = blocks_log_likelihood(torch.as_tensor(campaign["y"]), torch.as_tensor(campaign["eta"]), blocks,
                                "matern32", s, ell, 0.05, method)
    for b in range(2):
        g = [0, 1] if per_line else [0, 0]
        want = scipy_deleted(campaign, b, [float(s[b, i]) for i in g], [float(ell[b, i]) for i in g], 0.05)
        assert got[b].item() == pytest.approx(want, abs=1e-9, rel=1e-12)


def test_blocks_group_load_cases_with_the_same_readings(campaign: dict) -> None:
    blocks = make_blocks(campaign["x"], campaign["mask"], SLICES, NOISE)
    assert all(b.loads.numel() == 1 for b in blocks)  # every load case has its own dropouts
    assert sum(b.size for b in blocks) == int(campaign["mask"].sum())
    full = make_blocks(campaign["x"], full_mask(3, 55), SLICES, 0.2)
    assert [(b.line, b.loads.tolist(), b.points.numel(), b.sigma_e) for b in full] == [
        ("bottom", [0, 1, 2], 30, 0.2), ("top", [0, 1, 2], 25, 0.2)]


def test_one_unmasked_line_is_the_plain_likelihood(campaign: dict) -> None:
    """One block over every load case and position: the same call as log_likelihood, bit for bit."""
    x, eta = campaign["x"][:30], torch.as_tensor(campaign["eta"][:, :, :30])
    y = torch.as_tensor(campaign["eta"][0, :, :30] + 0.5)
    blocks = make_blocks(x, full_mask(3, 30), {None: slice(0, 30)}, 0.1)
    s, ell = torch.tensor([1.0, 2.0]), torch.tensor([0.5, 3.0])
    got = blocks_log_likelihood(y, eta, blocks, "matern32", s[:, None], ell[:, None], 0.05)
    assert torch.equal(got, log_likelihood(y, eta, x, "matern32", s, ell, 0.05, 0.1))


def test_coordinates_are_dense_or_fullscale_and_refused_in_the_state_space() -> None:
    kern = get_kernel("matern32")
    assert choose_method(kern, 4999, "auto", dim=2) == "dense"
    assert choose_method(kern, 10**7, "auto", dim=2) == "fullscale"
    with pytest.raises(ValueError, match="2-D coordinates: no state-space form"):
        choose_method(kern, 50, "state_space", dim=2)
    with pytest.raises(ValueError, match="GiB"):
        choose_method(kern, 10**7, "dense", dim=2)


def test_a_load_case_without_valid_reading_is_refused() -> None:
    mask = np.ones((2, 4), dtype=bool)
    mask[1] = False
    with pytest.raises(ValueError, match="load case index 1 has no valid reading"):
        make_blocks(np.arange(4.0), mask, {None: slice(0, 4)}, 0.1)

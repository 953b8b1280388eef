"""Bridge 705's surrogate: the paper's grid and the shipped GP against the finite element model.

If the finite element model changes, these tests fail until the shipped file is regenerated
with ``python scripts/make_surrogate.py``.
"""

from __future__ import annotations


import pytest
import torch

import torchshm
from torchshm.casestudy.surrogate import (
    POSTERIOR_BOX, PRIOR_BOX, bridge705_surrogate, paper_design,
)
from torchshm.surrogate import Surrogate, surrogate_errors, uniform_in_box


@pytest.fixture(scope="module")
def model():
    return torchshm.bridge705()


@pytest.fixture(scope="module")
def shipped() -> Surrogate:
    return bridge705_surrogate()


def test_loads_without_the_model() -> None:
    # Load time is measured in scripts/bench_surrogate.py, not asserted here.
    sur = torchshm.bridge705_surrogate()
    assert isinstance(sur, Surrogate)


def test_trained_on_the_current_model(shipped: Surrogate, model) -> None:
    assert shipped.model_identity == model.identity, (
        "the finite element model changed: run python scripts/make_surrogate.py")
    torch.testing.assert_close(shipped.theta_p, paper_design())
    torch.testing.assert_close(shipped.outputs, model(paper_design()), rtol=0, atol=1e-7)  # thread-count rounding is ~1e-8 µε


def test_same_forward_model_contract(shipped: Surrogate, model) -> None:
    torch.testing.assert_close(shipped.x, model.x)
    torch.testing.assert_close(shipped.loads, model.loads)
    assert shipped.names == tuple(model.names)
    theta = uniform_in_box(6, PRIOR_BOX, seed=5).reshape(2, 3, 2)
    assert shipped(theta).shape == model(theta).shape == (2, 3, 12, 351)
    assert shipped.variance(theta).shape == (2, 3, 12, 351)


def test_accuracy_in_the_prior_box(shipped: Surrogate, model) -> None:
    """40 held-out runs, E_c ~ U(10, 100), log10 K_r ~ U(0, 12): within 1 % of each run's peak."""
    errors = surrogate_errors(shipped, model, uniform_in_box(40, PRIOR_BOX, seed=2024))
    assert errors.max_rel_run_peak <= 0.01, errors.line()


def test_accuracy_in_the_posterior_region(shipped: Surrogate, model) -> None:
    """40 held-out runs, E_c in 25-45 GPa, log10 K_r in 10.5-12: within 0.05 µε."""
    errors = surrogate_errors(shipped, model, uniform_in_box(40, POSTERIOR_BOX, seed=2025))
    assert errors.max_abs <= 0.05, errors.line()


def test_variance_is_small_at_the_design_and_non_negative(shipped: Surrogate) -> None:
    at_design = shipped.variance(paper_design())
    away = shipped.variance(uniform_in_box(100, PRIOR_BOX, seed=7))
    assert bool((at_design >= 0).all()) and bool((away >= 0).all())
    assert float(at_design.max().sqrt()) < 1e-3  # µε, against σ_e = 0.1 µε


def test_paper_design_is_the_7_by_16_grid() -> None:
    design = paper_design()
    assert design.shape == (112, 2) and design.dtype == torch.float64
    e_c, log_k = design[:, 0].unique(), design[:, 1].unique()
    torch.testing.assert_close(e_c, torch.linspace(10.0, 100.0, 7, dtype=torch.float64))
    torch.testing.assert_close(log_k, torch.linspace(0.0, 12.0, 16, dtype=torch.float64))
    assert design.unique(dim=0).shape[0] == 112


def test_the_bridge_names_belong_to_the_case_study() -> None:
    import torchshm.casestudy as case
    import torchshm.surrogate as generic

    assert case.paper_design is paper_design and case.PRIOR_BOX == PRIOR_BOX
    assert torchshm.bridge705_surrogate is bridge705_surrogate
    assert not hasattr(generic, "paper_design") and not hasattr(generic, "bridge705_surrogate")

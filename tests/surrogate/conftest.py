"""Fixtures of the surrogate tests: a stand-in frame model, a small design, a fitted surrogate."""

from __future__ import annotations

import pytest
import torch
from torch import Tensor

from standin_frame import StandInFrame
from torchshm.surrogate import Surrogate, fit_surrogate, grid_design


@pytest.fixture(scope="session")
def standin() -> StandInFrame:
    return StandInFrame()


@pytest.fixture(scope="session")
def small_design() -> Tensor:
    """6 x 10 grid over the prior box."""
    return grid_design(torch.linspace(10.0, 100.0, 6), torch.linspace(0.0, 12.0, 10))


@pytest.fixture(scope="session")
def fitted(standin: StandInFrame, small_design: Tensor) -> Surrogate:
    return fit_surrogate(standin, small_design)

"""Fixtures of the Problem tests: small forward models and their synthetic data."""

from __future__ import annotations

import numpy as np
import pytest
from problem_models import PAPER_LOADS, LinearModel, c1_positions, synthetic

from torchshm.data import Measurements


@pytest.fixture
def small() -> tuple[LinearModel, Measurements]:
    """Model with 12 loads x 61 positions; measurements of 3 loads x 31 positions (every other)."""
    x = np.round(35.0 + 0.05 * np.arange(61), 10)
    model = LinearModel(x)
    return model, synthetic(model, (39.8, 16.9, 62.8), x[::2])


@pytest.fixture
def c1() -> tuple[LinearModel, Measurements]:
    """Sub-case C1 size: 11 load cases x 351 positions."""
    model = LinearModel(c1_positions())
    return model, synthetic(model, PAPER_LOADS[:11], c1_positions())

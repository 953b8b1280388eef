"""Designs of physical parameters."""

from __future__ import annotations

import torch

from torchshm.surrogate import grid_design


def test_grid_design_varies_the_last_parameter_fastest() -> None:
    design = grid_design(torch.tensor([1.0, 2.0]), torch.tensor([5.0, 6.0, 7.0]))
    expected = [[1, 5], [1, 6], [1, 7], [2, 5], [2, 6], [2, 7]]
    torch.testing.assert_close(design, torch.tensor(expected, dtype=torch.float64))

"""The paper's training grid."""

from __future__ import annotations

import torch

from torchshm.surrogate import grid_design, paper_design


def test_paper_design_is_the_7_by_16_grid() -> None:
    design = paper_design()
    assert design.shape == (112, 2) and design.dtype == torch.float64
    e_c, log_k = design[:, 0].unique(), design[:, 1].unique()
    torch.testing.assert_close(e_c, torch.linspace(10.0, 100.0, 7, dtype=torch.float64))
    torch.testing.assert_close(log_k, torch.linspace(0.0, 12.0, 16, dtype=torch.float64))
    assert design.unique(dim=0).shape[0] == 112


def test_grid_design_varies_the_last_parameter_fastest() -> None:
    design = grid_design(torch.tensor([1.0, 2.0]), torch.tensor([5.0, 6.0, 7.0]))
    expected = [[1, 5], [1, 6], [1, 7], [2, 5], [2, 6], [2, 7]]
    torch.testing.assert_close(design, torch.tensor(expected, dtype=torch.float64))

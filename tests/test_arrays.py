"""The shared array conversions."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from torchshm.arrays import as_float64, as_numpy, checked_array


def test_conversions_are_float64_and_keep_the_graph() -> None:
    t = torch.tensor([1.0, 2.0], dtype=torch.float32, requires_grad=True)
    out = as_float64(t)
    assert out.dtype == torch.float64 and out.requires_grad
    assert as_float64([[1, 2]]).dtype == torch.float64
    array = as_numpy(t)
    assert array.dtype == np.float64 and np.array_equal(array, [1.0, 2.0])


@pytest.mark.parametrize(
    ("values", "ndim", "message"),
    [("abc", None, "x is not numeric"), ([1.0, 2.0], 2, "x must be 2-D"),
     ([1.0, np.nan], 1, r"x has a NaN or inf value at index \(1,\)")],
)
def test_checked_array_names_the_input(values: object, ndim: int | None, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        checked_array(values, "x", ndim)

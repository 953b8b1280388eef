"""Problem refuses what the likelihood does not use yet: sensor lines, coordinates, masked readings."""

from __future__ import annotations

import numpy as np
import pytest

from torchshm import Measurements
from torchshm.problem import Problem


@pytest.mark.parametrize("m", [
    Measurements([0.0, 0.1, 0.0], [[1.0, 2.0, 3.0]], [39.8], line=["a", "a", "b"]),
    Measurements([[0.0, 0.0], [0.1, 0.0]], [[1.0, 2.0]], [39.8]),
    Measurements([0.0, 0.1], [[1.0, np.nan]], [39.8], missing="mask"),
])
def test_problem_refuses_lines_fields_and_masks(m: Measurements) -> None:
    with pytest.raises(ValueError, match="not used by the likelihood yet"):
        Problem(None, m)  # type: ignore[arg-type]

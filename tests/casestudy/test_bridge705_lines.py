"""Bridge 705 with a second fibre on the top face of the deck (``bridge705(lines=2)``)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from torchshm import bridge705

THETA = torch.tensor([[37.6, 9.0], [30.0, 12.5]], dtype=torch.float64)


def test_two_lines_extend_the_one_fibre_model() -> None:
    one, two, top = bridge705(), bridge705(lines=2), bridge705(lines=("top",))
    n = one.x.numel()
    assert not hasattr(one, "line") and two.line.tolist() == ["bottom"] * n + ["top"] * n
    assert torch.equal(two.x, torch.cat([one.x, one.x]))
    out = two(THETA)
    # the bottom fibre is unchanged (to the rounding of a matrix product of another size)
    torch.testing.assert_close(out[..., :n], one(THETA), rtol=1e-12, atol=1e-12)
    torch.testing.assert_close(out[..., n:], top(THETA), rtol=1e-12, atol=1e-12)
    assert len({one.identity, two.identity, top.identity}) == 3


def test_top_face_is_the_bottom_mirrored_about_the_axis() -> None:
    """Strain is linear across the depth: top = 2 axial - bottom, and for the symmetric deck
    section the axial part is small next to bending (the frame carries little axial force)."""
    out = bridge705(lines=2)(THETA)
    n = out.shape[-1] // 2
    bottom, top = out[..., :n], out[..., n:]
    axial = 0.5 * (bottom + top)
    assert float(axial.abs().max()) < 0.1 * float(bottom.abs().max())
    assert float((bottom * top).sum()) < 0  # opposite signs


@pytest.mark.parametrize("lines", [3, "top", ("top", "top"), ("side",), ()])
def test_bad_lines_are_refused(lines: object) -> None:
    with pytest.raises(ValueError, match="bridge705: lines"):
        bridge705(lines=lines)  # type: ignore[arg-type]

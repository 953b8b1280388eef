"""Array conversions shared by every package: float64 tensors and float64 numpy arrays.

Every public function of torchshm accepts numpy arrays, tensors and nested sequences; they are
converted here, once, with one rule: float64, tensors keep their device and autograd graph when
a tensor is wanted, and are detached to the CPU when a numpy array is wanted.
"""

from __future__ import annotations

import numpy as np
import torch
from torch import Tensor


def as_float64(values: object) -> Tensor:
    """Float64 tensor of an array-like; tensors keep their device and autograd graph."""
    if isinstance(values, Tensor):
        return values.to(torch.float64)
    return torch.as_tensor(np.array(values, dtype=np.float64, order="C"))


def as_numpy(values: object) -> np.ndarray:
    """Float64 numpy array of an array-like or tensor (a tensor is detached and moved to the CPU).

    Raises:
        ValueError: if ``values`` is not numeric.
    """
    if isinstance(values, Tensor):
        return values.detach().cpu().numpy().astype(np.float64)
    return np.asarray(values, dtype=np.float64)


def checked_array(values: object, name: str, ndim: int | None = None) -> np.ndarray:
    """A float64 numpy copy of ``values`` that is numeric, finite and ``ndim``-dimensional.

    Args:
        values: array-like or tensor.
        name: its name in error messages.
        ndim: required number of dimensions, or ``None`` for any.

    Raises:
        ValueError: naming ``name``, if it is not numeric, has the wrong dimension or holds a
            NaN or inf.
    """
    try:
        array = np.array(as_numpy(values), dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise ValueError(f"{name} is not numeric ({err})") from None
    if ndim is not None and array.ndim != ndim:
        raise ValueError(f"{name} must be {ndim}-D, got shape {array.shape}")
    if not np.all(np.isfinite(array)):
        bad = tuple(int(i) for i in np.argwhere(~np.isfinite(array))[0])
        raise ValueError(f"{name} has a NaN or inf value at index {bad}")
    return array

"""What a forward model is.

A forward model maps physical parameters to strains at the sensor points for every load case it
knows, all at once, so that load cases held out of inference need no new model runs later.
"""

from __future__ import annotations

import hashlib
from typing import Protocol, runtime_checkable

from torch import Tensor

from torchshm.arrays import as_float64


@runtime_checkable
class ForwardModel(Protocol):
    """Structural protocol of a forward model.

    Attributes:
        x: `n` sensor positions along the fibre [m], or `n x d` coordinates [m] of a field
            (e.g. image correlation), float64.
        loads: `L` load cases, identified by the truck's front-axle position [m], float64.

    Optional attributes, read where present: ``names`` (the `P` parameter names), ``identity``
    (:func:`model_identity`), ``line`` (`n` line labels), ``surrogate_transform`` and
    ``default_priors()`` (name -> prior, used by ``Problem(priors=None)``).
    """

    x: Tensor
    loads: Tensor

    def __call__(self, theta_p: Tensor) -> Tensor:
        """Strains [µε] `... x L x n` for physical parameters `theta_p` (`... x P`)."""
        ...


#: float64 tensor of an array-like (tensors keep their autograd graph): :func:`torchshm.arrays.as_float64`
as_tensor = as_float64


def model_identity(model: object) -> str:
    """Stable key of a forward model's configuration, used by the evaluation store.

    Returns ``model.identity`` when the model defines it; otherwise a hash of the model's class
    name, sensor positions and load cases. Two models with the same identity must return the same
    strains for the same parameters.
    """
    identity = getattr(model, "identity", None)
    if identity is not None:
        return str(identity)
    digest = hashlib.sha256(type(model).__qualname__.encode())
    for name in ("x", "loads"):
        values = getattr(model, name, None)
        if values is None:
            raise ValueError(f"forward model {type(model).__name__} has no attribute {name!r}")
        digest.update(as_tensor(values).detach().cpu().numpy().tobytes())
    return f"{type(model).__qualname__}-{digest.hexdigest()[:16]}"


def output_shape(model: object) -> tuple[int, int]:
    """Shape `(L_model, n_model)` of the strains a forward model returns for one θp.

    Raises:
        ValueError: if the model lacks ``x`` or ``loads``, ``loads`` is not one-dimensional or
            ``x`` is neither `n` positions nor `n x d` coordinates.
    """
    sizes = []
    for name in ("loads", "x"):
        values = getattr(model, name, None)
        if values is None:
            raise ValueError(f"forward model {type(model).__name__} has no attribute {name!r}")
        array = as_tensor(values)
        if array.ndim != 1 and not (name == "x" and array.ndim == 2):
            shape = "one-dimensional" if name == "loads" else "(n,) positions or (n, d) coordinates"
            raise ValueError(
                f"forward model {type(model).__name__}: {name!r} must be {shape}, "
                f"got shape {tuple(array.shape)}"
            )
        sizes.append(int(array.shape[0]))
    return sizes[0], sizes[1]

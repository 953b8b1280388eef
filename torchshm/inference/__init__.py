"""Identification: VBMC and emcee runs, the :class:`Posterior`, and TensorBoard traces.

The public names are imported on first use (as the package ``torchshm``'s), so that a submodule
such as :mod:`torchshm.inference.peer_errors` loads without the methods' libraries (PyVBMC,
emcee, scikit-learn, ArviZ): a command that refuses its input does not pay for them.
"""

from __future__ import annotations

from torchshm._lazy import lazy_dir, lazy_getattr

#: public name -> module that defines it
_EXPORTS: dict[str, str] = {
    "identify": "torchshm.inference.identify",
    "load_posterior": "torchshm.inference.netcdf_load",
    "Posterior": "torchshm.inference.posterior",
    "PosteriorSummary": "torchshm.inference.posterior",
    "SummaryRow": "torchshm.inference.posterior",
}

__all__ = sorted(_EXPORTS)

__getattr__ = lazy_getattr("torchshm.inference", _EXPORTS, globals())
__dir__ = lazy_dir(_EXPORTS, globals())

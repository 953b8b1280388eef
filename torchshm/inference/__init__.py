"""Identification: VBMC and emcee runs, the :class:`Posterior`, and TensorBoard traces."""

from __future__ import annotations

from torchshm.inference.identify import identify
from torchshm.inference.netcdf_load import load_posterior
from torchshm.inference.posterior import Posterior, PosteriorSummary, SummaryRow

__all__ = ["Posterior", "PosteriorSummary", "SummaryRow", "identify", "load_posterior"]

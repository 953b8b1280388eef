"""After inference: posterior predictive, Bayes factors and KL divergence (paper, Sec. 2.4)."""

from __future__ import annotations

from torchshm.predictive.bayes import JEFFREYS, BayesFactors, bayes_factors, jeffreys_label
from torchshm.predictive.draws import predictive_draws
from torchshm.predictive.emulator import fit_emulator
from torchshm.predictive.kl import KLEstimate, kl_divergence
from torchshm.predictive.metrics import (
    PredictiveMetrics,
    coverage,
    mean_interval_width,
    mse,
    predictive_metrics,
    r2_score,
)
from torchshm.predictive.posterior_predictive import exact_predictive, posterior_predictive
from torchshm.predictive.result import PredictiveResult

__all__ = [
    "JEFFREYS",
    "BayesFactors",
    "KLEstimate",
    "PredictiveMetrics",
    "PredictiveResult",
    "bayes_factors",
    "coverage",
    "exact_predictive",
    "fit_emulator",
    "jeffreys_label",
    "kl_divergence",
    "mean_interval_width",
    "mse",
    "posterior_predictive",
    "predictive_draws",
    "predictive_metrics",
    "r2_score",
]

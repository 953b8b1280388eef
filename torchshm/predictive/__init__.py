"""After inference: posterior predictive, Bayes factors and KL divergence (paper, Sec. 2.4)."""

from __future__ import annotations

from torchshm.predictive.bayes import JEFFREYS, BayesFactors, bayes_factors, jeffreys_label
from torchshm.predictive.check import EmulatorCheck, emulator_check
from torchshm.predictive.draws import predictive_draws
from torchshm.predictive.emulator import fit_emulator
from torchshm.predictive.kl import KLEstimate, kl_divergence
from torchshm.predictive.memory import predictive_memory
from torchshm.predictive.metrics import (
    PredictiveMetrics,
    coverage,
    mean_interval_width,
    metrics_table,
    mse,
    predictive_metrics,
    r2_score,
)
from torchshm.predictive.predictive import exact_predictive, posterior_predictive, stored_emulator
from torchshm.predictive.result import PredictiveResult
from torchshm.predictive.view import PredictionView, prediction_view

__all__ = [
    "JEFFREYS",
    "BayesFactors",
    "EmulatorCheck",
    "KLEstimate",
    "PredictiveMetrics",
    "PredictionView",
    "PredictiveResult",
    "bayes_factors",
    "coverage",
    "emulator_check",
    "exact_predictive",
    "fit_emulator",
    "jeffreys_label",
    "kl_divergence",
    "mean_interval_width",
    "metrics_table",
    "mse",
    "posterior_predictive",
    "predictive_draws",
    "predictive_memory",
    "prediction_view",
    "predictive_metrics",
    "r2_score",
    "stored_emulator",
]

"""The posterior predictive and the KL divergence on every kind of campaign.

Campaigns (:mod:`campaigns_predictive`): one fibre; two fibres with 5 % dropouts and a 40 cm gap
per load case; positions between the model's (``match="interpolate"``); a per-line
discrepancy; the 2-D plate field. Posteriors are draws near the truth with an emcee-like
posterior (samples, no density), so the KL comes from a fitted mixture.
"""

from __future__ import annotations

import numpy as np
import pytest

from campaigns_predictive import CAMPAIGNS, campaign
from torchshm.predictive import kl_divergence, metrics_table, posterior_predictive


@pytest.mark.parametrize("kind", CAMPAIGNS)
def test_predictive_and_kl_on_every_campaign(kind: str) -> None:
    c = campaign(kind, n_samples=800)
    loads = [float(v) for v in c.held_out.loads]
    calls = c.problem.n_model_evaluations
    pred = posterior_predictive(c.post, loads, n=200, seed=0)
    assert c.problem.n_model_evaluations == calls  # no model run
    n = c.problem.measurements.n
    assert pred.mean.shape == (len(loads), n) and pred.samples.shape == (200, len(loads), n)
    assert bool((pred.lower <= pred.upper).all()) and bool(pred.samples.isfinite().all())
    assert tuple(pred.x.shape) == np.shape(c.problem.measurements.x)
    lines = [str(v) for v in c.problem.measurements.lines if v is not None]
    assert [str(v) for v in pred.lines if v is not None] == lines

    rows = metrics_table(pred, c.held_out)
    assert len(rows) == len(loads) * (len(lines) + 1 if len(lines) > 1 else 1)
    for row in rows:  # draws near the truth predict the held-out data
        assert 0.85 <= row["coverage"] <= 1.0 and row["r2"] > 0.9, row
    pooled = [r for r in rows if r["line"] == "all"]
    measured = np.isfinite(c.held_out.y).sum(axis=1)
    assert [r["n_points"] for r in pooled] == measured.tolist()  # dropouts are not scored

    ds = pred.to_xarray()
    assert ds["mean"].dims == ("load", "point")
    assert ("line" in ds.coords) == bool(lines) and ("y" in ds.coords) == (kind == "plate")

    kl = kl_divergence(c.post, n=800, seed=0)
    assert kl.source == "fitted mixture" and np.isfinite(kl.value) and kl.value > 0
    assert 0 < kl.se < 0.5 and abs(kl.density_error) < 1.0

"""Every method on every campaign: identify, predict held-out load cases, KL, Bayes factors, CLI.

Methods {vbmc, emcee, emulator} x campaigns (:mod:`campaigns_predictive`): one fibre; two
fibres with 5 % dropouts and a 40 cm gap per load case; positions between the model's
(``match="interpolate"``); a per-line discrepancy; the 2-D plate field. Each combination must
run end to end (none refused); the budgets are far below convergence, so the tests check that
every output exists and is finite, not its accuracy (``scripts/bench_campaigns.py`` measures
that). The CLI runs once per campaign shape, in-process, with the model given by a model
config (``model._target_``) as a user's would be, with emcee (the cheapest method at a tiny
budget; the matrix runs the CLI's steps for every method).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from hydra import compose, initialize_config_dir

import torchshm
from campaigns_predictive import CAMPAIGNS, ROOT, campaign_problem
from torchshm.data import with_dropouts
from torchshm.config import CONF_DIR, CONFIG_NAME, register_configs, to_settings
from torchshm.predictive import bayes_factors, kl_divergence, metrics_table, posterior_predictive

#: budgets far below convergence: each identification costs a few seconds of CPU
BUDGETS = {
    "vbmc": {"max_fun_evals": 20, "display": "off", "n_samples": 600},
    "emcee": {"n_walkers": 40, "burn": 4},  # n_steps: 100 D kept draws, the fewest KL's mixture takes
    "emulator": {"max_model_evaluations": 10, "n_walkers": 24, "n_steps": 20, "final_steps": 30,
                 "n_evidence": 600, "error_draws": 2},
}


@pytest.mark.slow
@pytest.mark.parametrize("method", list(BUDGETS))
@pytest.mark.parametrize("kind", CAMPAIGNS)
def test_every_method_on_every_campaign(kind: str, method: str) -> None:
    problem, held_out = campaign_problem(kind, resolution=0.5)
    options = dict(BUDGETS[method])
    if method == "emcee":
        options["n_steps"] = 4 + math.ceil(100 * len(problem.names) / 40)
    post = torchshm.identify(problem, method, seed=0, **options)
    assert np.isfinite(post.samples).all() and post.samples.shape[1] == len(problem.names)

    loads = [float(v) for v in held_out.loads]
    calls = problem.n_model_evaluations
    pred = posterior_predictive(post, loads, n=100, seed=0)
    assert problem.n_model_evaluations == calls  # predicted from the runs made, none new
    assert pred.mean.shape == (len(loads), problem.measurements.n) and bool(pred.samples.isfinite().all())
    lines = [v for v in problem.measurements.lines if v is not None]
    rows = metrics_table(pred, held_out)
    assert len(rows) == len(loads) * (len(lines) + 1 if len(lines) > 1 else 1)
    assert all(0.0 <= r["coverage"] <= 1.0 and math.isfinite(r["mse"]) for r in rows)

    kl = kl_divergence(post, n=600, seed=0)
    assert math.isfinite(kl.value) and kl.source == ("fitted mixture" if method == "emcee" else "posterior density")
    if method == "emcee":  # no evidence: refused with its reason, the one place a refusal is right
        with pytest.raises(ValueError, match="no log evidence"):
            bayes_factors({"this": post, "other": 0.0})
    else:
        factors = bayes_factors({"this": post, "one nat less": (post.log_evidence - 1.0, 0.1)})
        assert abs(factors.log10[0, 1] - 1.0 / math.log(10.0)) < 1e-9


def _cli_overrides(kind: str, tmp_path: Path) -> list[str]:
    """The command-line overrides of campaign ``kind`` (files written into ``tmp_path``)."""
    fe = ["model._target_=torchshm.bridge705", "data.loads=[39.8]", "predict.loads=[55.1]",
          "data.resolution=0.5"]
    if kind == "plate":
        return [f"hydra.searchpath=[file://{ROOT / 'examples/plate_dic/conf'}]", "model=plate_dic",
                "priors=plate_dic", f"data.path={ROOT / 'examples/plate_dic/campaign.csv'}",
                "data.loads=[0.5,1.5]", "predict.loads=[1.0]", "data.resolution=null",
                "likelihood.sigma_m=0.02"]
    if kind == "one_fibre":
        return fe
    if kind == "per_line":
        return [*fe, "+model.lines=2", "data.lines=2", "likelihood.discrepancy=per_line"]
    data = torchshm.synthetic_campaign(0, lines=2 if kind == "two_fibres_dropouts" else 1)
    if kind == "two_fibres_dropouts":
        data, model = with_dropouts(data, fraction=0.05, gap=0.4, seed=1), ["+model.lines=2"]
    else:  # interpolate: readings between the model's positions
        x = data.x[:-1] + 0.04
        data = torchshm.Measurements(x, np.stack([np.interp(x, data.x, row) for row in data.y]),
                                     data.loads, sigma_e=data.sigma_e, attrs=data.attrs)
        model = ["likelihood.match=interpolate"]
    path = data.save(tmp_path / "campaign.csv")
    return [*fe, *model, f"data.path={path}"]


@pytest.mark.slow
@pytest.mark.parametrize("kind", CAMPAIGNS)
def test_the_cli_writes_every_output_on_every_campaign(kind: str, tmp_path: Path) -> None:
    from torchshm.cli.job import prepare_job, run_job

    register_configs()
    overrides = ["method=emcee", "method.n_walkers=24", "method.n_steps=12", "method.burn=2",
                 "method.log_every=5", "predict.n=100",
                 *_cli_overrides(kind, tmp_path)]
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        settings = to_settings(compose(CONFIG_NAME, overrides=overrides))
    out = tmp_path / "run"
    result = run_job(prepare_job(settings, base=ROOT), out)
    for name in ("posterior", "summary", "corner", "predictive", "run"):
        assert result.files[name].is_file(), name
    figures = [k for k in result.files if k.startswith("predictive_map_")] if kind == "plate" \
        else ["predictive_plot"]
    assert figures and all(result.files[k].stat().st_size > 10_000 for k in figures)
    record = json.loads(result.files["run"].read_text())
    assert record["predictive"]
    info = record["information"]  # 240 draws: too few for KL's mixture in 4-6 dimensions, said so
    assert math.isfinite(info["kl"]) if info["kl"] is not None else "too few" in info["kl_reason"]

"""The comparison table of a sweep, from the run.json of each job folder."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import pytest

from torchshm.cli.sweep import compare_runs


def job(sweep: Path, name: str, record: dict | None) -> None:
    folder = sweep / name
    (folder / ".hydra").mkdir(parents=True)
    if record is not None:
        (folder / "run.json").write_text(json.dumps(record))


def record(elbo: float, sd: float, coverage: list[float], runs: int) -> dict:
    return {"method": "vbmc", "log_evidence": elbo, "log_evidence_sd": sd, "converged": True,
            "n_model_evaluations": runs, "wall_time_s": 1.0,
            "predictive": [{"load": 1.0 + i, "coverage": c} for i, c in enumerate(coverage)]}


def test_comparison_of_three_kernels(tmp_path: Path) -> None:
    job(tmp_path, "kernel=exponential", record(-110.0, 0.1, [0.9, 1.0], 60))
    job(tmp_path, "kernel=matern32", record(-100.0, 0.1, [0.95], 55))
    job(tmp_path, "kernel=matern52", record(-101.5, 0.2, [], 50))
    job(tmp_path, "kernel=squared_exponential", None)  # a failed job
    files = compare_runs(tmp_path)
    with open(files["csv"]) as f:
        rows = {r["job"]: r for r in csv.DictReader(f)}
    assert rows["kernel=matern32"]["jeffreys"] == "best"
    assert float(rows["kernel=matern32"]["log10_B_best_over_job"]) == 0.0
    b = float(rows["kernel=exponential"]["log10_B_best_over_job"])
    assert b == pytest.approx(10.0 / math.log(10.0), rel=1e-12)  # 4.34: decisive
    assert rows["kernel=exponential"]["jeffreys"] == "Decisive"
    assert float(rows["kernel=matern52"]["log10_B_best_over_job"]) == pytest.approx(1.5 / math.log(10.0))
    assert rows["kernel=matern52"]["jeffreys"] == "Substantial"  # 0.65
    assert float(rows["kernel=exponential"]["holdout_coverage"]) == pytest.approx(0.95)
    assert rows["kernel=matern52"]["holdout_coverage"] == ""
    assert rows["kernel=matern32"]["model_runs"] == "55"
    assert rows["kernel=squared_exponential"]["status"] == "failed"
    text = files["markdown"].read_text()
    assert "| kernel=exponential | vbmc | -110.00 ± 0.10 | 4.34 | Decisive | 95.0 % | 60 |" in text
    pairs = files["bayes_factors"].read_text().splitlines()
    assert len(pairs) == 1 + 3 * 2


def test_one_job_has_no_bayes_factor(tmp_path: Path) -> None:
    job(tmp_path, "kernel=matern32", record(-100.0, 0.1, [1.0], 55))
    files = compare_runs(tmp_path)
    assert "bayes_factors" not in files and files["markdown"].is_file()


def test_emcee_jobs_have_no_elbo(tmp_path: Path) -> None:
    for name in ("a", "b"):
        job(tmp_path, name, {**record(0.0, 0.0, [0.9], 10), "method": "emcee", "log_evidence": None,
                             "log_evidence_sd": None})
    files = compare_runs(tmp_path)
    with open(files["csv"]) as f:
        rows = list(csv.DictReader(f))
    assert [r["elbo"] for r in rows] == ["", ""] and [r["model_runs"] for r in rows] == ["10", "10"]


def test_jobs_are_named_by_the_overrides_that_differ(tmp_path: Path) -> None:
    for i, kernel in enumerate(("exponential", "matern32")):
        folder = f"job{i}"
        job(tmp_path, folder, record(-100.0 - i, 0.1, [1.0], 10))
        (tmp_path / folder / ".hydra" / "overrides.yaml").write_text(
            f"- model=two_span_beam\n- kernel={kernel}\n- data.loads=[10.0]\n")
    files = compare_runs(tmp_path)
    with open(files["csv"]) as f:
        rows = list(csv.DictReader(f))
    assert [(r["job"], r["folder"]) for r in rows] == [("kernel=exponential", "job0"),
                                                       ("kernel=matern32", "job1")]


def test_empty_sweep_folder(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="no job folder"):
        compare_runs(tmp_path)


def test_the_warnings_of_each_job_are_named_in_the_table(tmp_path: Path) -> None:
    lines = ["NOT CONVERGED: VBMC stopped after 40 evaluations ...",
             "PRIOR BOUND: E_c piles at its upper prior bound 60: 41% of the posterior ..."]
    job(tmp_path, "seed=0", {**record(-100.0, 0.1, [1.0], 40), "converged": False, "warnings": lines})
    job(tmp_path, "seed=1", record(-100.5, 0.1, [1.0], 80))
    files = compare_runs(tmp_path)
    with open(files["csv"]) as f:
        rows = {r["job"]: r for r in csv.DictReader(f)}
    assert rows["seed=0"]["warnings"] == "NOT CONVERGED; PRIOR BOUND (E_c upper)"
    assert rows["seed=1"]["warnings"] == ""
    text = files["markdown"].read_text()
    assert "| 40 | False | NOT CONVERGED; PRIOR BOUND (E_c upper) | ok |" in text


def test_kl_and_bayes_factor_columns_say_where_they_come_from(tmp_path: Path) -> None:
    vbmc = {**record(-100.0, 0.1, [0.9], 50), "information": {
        "evidence": "vbmc log evidence", "kl": 3.21, "kl_se": 0.01, "kl_source": "posterior density"}}
    emcee = {**record(0.0, 0.0, [0.8], 10), "method": "emcee", "log_evidence": None, "log_evidence_sd": None,
             "information": {"evidence": "not defined: emcee computes no evidence", "kl": 3.4, "kl_se": 0.05,
                             "kl_source": "fitted mixture", "kl_density_error": 0.02},
             "predictive": [{"load": 1.0, "line": "a", "coverage": 0.5},
                            {"load": 1.0, "line": "all", "coverage": 0.8}]}
    job(tmp_path, "method=vbmc", vbmc)
    job(tmp_path, "method=emcee", emcee)
    files = compare_runs(tmp_path)
    with open(files["csv"]) as f:
        rows = {r["job"]: r for r in csv.DictReader(f)}
    assert rows["method=emcee"]["kl_source"] == "fitted mixture"
    assert rows["method=emcee"]["bayes_factor"].startswith("not defined")
    assert float(rows["method=emcee"]["holdout_coverage"]) == pytest.approx(0.8)  # the pooled row only
    text = files["markdown"].read_text()
    assert "| 3.21 ± 0.01 | posterior density | vbmc log evidence |" in text
    assert "| 3.40 ± 0.05 | fitted mixture | not defined: emcee computes no evidence |" in text

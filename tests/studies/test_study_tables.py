"""Study tables from the run folders of a sweep (studies/study_tables.py)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

import study_tables as study


def write_run(folder: Path, kernel: str, resolution: float, elbo: float, rows: list[dict], kl: float | None = None) -> None:
    folder.mkdir(parents=True)
    summary = {n: {"mean": 1.0, "sd": 0.1, "q2.5": 0.8, "q97.5": 1.2} for n in ("E_c", "log10_K_r", "sigma_a")}
    if kernel != "independent":
        summary["length"] = {"mean": 2.0, "sd": 0.2, "q2.5": 1.6, "q97.5": 2.4}
    record = {"method": "vbmc", "wall_time_s": 12.0, "n_model_evaluations": 150, "log_evidence": elbo,
              "log_evidence_sd": 0.1, "converged": True, "summary": summary, "predictive": rows,
              "settings": {"kernel": {"name": kernel}, "data": {"loads": [39.8], "resolution": resolution}}}
    if kl is not None:
        record["kl_divergence"], record["kl_divergence_se"] = kl, 0.01
    (folder / "run.json").write_text(json.dumps(record))


def row(load: float, coverage: float, n: int = 100) -> dict:
    return {"load": load, "coverage": coverage, "r2": 0.9, "mse": 2.0 * coverage, "mean_width": 3.0, "n_points": n}


@pytest.fixture
def sweep(tmp_path: Path) -> Path:
    write_run(tmp_path / "kernel=independent", "independent", 0.1, -300.0,
              [row(39.8, 0.96), row(55.1, 0.70), row(70.4, 0.80, 300)])
    write_run(tmp_path / "kernel=matern32", "matern32", 0.1, -250.0,
              [row(39.8, 0.97), row(55.1, 0.90), row(70.4, 0.90)], kl=9.5)
    return tmp_path


def test_records_and_pooled_scores(sweep: Path) -> None:
    records = study.read_sweep(sweep)
    assert [r.kernel for r in records] == ["independent", "matern32"]
    indep = records[0]
    assert indep.held_out_loads() == [55.1, 70.4]
    held = indep.scores(held_out=True)
    assert held["coverage"] == pytest.approx((0.70 * 100 + 0.80 * 300) / 400) and held["n_points"] == 400
    assert indep.scores(held_out=False)["coverage"] == pytest.approx(0.96)
    assert indep.scores(loads=[70.4])["mse"] == pytest.approx(1.6)
    assert math.isnan(indep.scores(loads=[10.5])["coverage"])


def test_tables(sweep: Path) -> None:
    records = study.order_records(study.read_sweep(sweep), lambda r: r.kernel, ["matern32", "independent"])
    label = lambda r: r.kernel  # noqa: E731
    assert [r.kernel for r in records] == ["matern32", "independent"]
    t8 = study.parameter_table(records, label).splitlines()
    assert t8[2].startswith("| matern32 | 1.00 [0.80, 1.20]") and t8[3].endswith("| – |")
    bf = study.evidence_table(records, label)
    assert bf.log10[0, 1] == pytest.approx(50 / math.log(10)) and bf.labels[0][1] == "Decisive"
    t10 = study.coverage_table(records, label)
    assert "| independent | 96.00 % | 77.50 % |" in t10
    assert "| matern32 | 9.50 ± 0.01 |" in study.kl_table(records, label)
    assert "| independent | – |" in study.kl_table(records, label)
    assert "| matern32 | 0.900 | 1.800 | 3.000 |" in study.prediction_table(records, label, 70.4)
    assert "| matern32 | 150 | yes | -250.00 ± 0.10 | 12 |" in study.run_table(records, label)

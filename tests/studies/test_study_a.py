"""``studies/study_a.py`` with tiny budgets writes Table 5, Figs. 4-6 and its numbers."""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_study_a_smoke(tmp_path: Path) -> None:
    args = ["--out", "runs/study_a", "--vbmc-max-fun-evals", "20", "--emcee-walkers", "8",
            "--emcee-steps", "40", "--window", "80", "resolution=4"]
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    result = subprocess.run([sys.executable, str(REPO / "studies" / "study_a.py"), *args], cwd=tmp_path,
                            env=env, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr[-2000:]
    out = tmp_path / "runs" / "study_a"
    for name in ("table5.csv", "table5.md", "fig4_corner.png", "fig5_emcee_convergence.png",
                 "fig6_vbmc_convergence.png", "study_a.json", "study_a.md", "emcee_chain.h5",
                 "vbmc_posterior.nc", "emcee_posterior.nc"):
        assert (out / name).is_file(), name
    with open(out / "table5.csv") as f:
        rows = list(csv.DictReader(f))
    assert [r["parameter"] for r in rows] == ["E_c", "log10_K_r", "sigma_a", "length"]
    assert all(float(r["mcmc_sd"]) > 0 and float(r["vbmc_sd"]) > 0 for r in rows)
    numbers = json.loads((out / "study_a.json").read_text())
    assert numbers["emcee"]["samples_total"] == 8 * 40
    assert numbers["vbmc"]["log_joint_evaluations_at_end"] > 0
    assert set(numbers["comparison"]) == {"E_c", "log10_K_r", "sigma_a", "length"}


def test_study_a_bad_override_is_one_line(tmp_path: Path) -> None:
    result = subprocess.run([sys.executable, str(REPO / "studies" / "study_a.py"), "kernel=foo"],
                            cwd=tmp_path, capture_output=True, text=True, timeout=120,
                            env={k: v for k, v in os.environ.items() if k != "HYDRA_FULL_ERROR"})
    assert result.returncode == 2
    assert result.stderr.splitlines() == [result.stderr.strip()]
    assert "Could not find 'kernel/foo'" in result.stderr

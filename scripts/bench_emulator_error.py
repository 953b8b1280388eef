"""How well the emulated log-likelihood's sd predicts the emulator's real error, case by case.

For each identification case (``benchmarks/``: the suite's and the held-out ones), the field
emulator of the adaptive method is fitted to a design like the method's early rounds (a Latin
hypercube of the plausible box, then draws of the reference posterior), and at test points
the true model gives the error ``Δ = ℓ(true strains) - ℓ(emulator mean)`` (Eq. 21, the same
covariance both times). Each model of the sd of Δ gives z-scores ``Δ / sd``; a calibrated model
has an rms of 1 and |z| > 3 in about 0.3 % of the points. Three models:

- ``diagonal``: independent reading errors through the diagonal of the Eq. (21) covariance,
  ``sqrt(Σ v r² / s⁴ + ½ Σ v² / s⁴)`` (the method's form before 2026-11-26);
- ``independent``: independent reading errors (as the emulator's outputs are) through the exact
  gradient ``g = ∂ℓ/∂η``: ``sqrt(Σ v g² + ½ Σ v² / s⁴)``;
- ``correlated``: the errors correlated across readings as the runs' fields are
  (:meth:`EmulatedLogJoint.error_variance`, the method's form).

Test points: "far", uniform in the plausible box of the physical parameters; "near", the
reference posterior's mean ± 2 sd. Usage::

    python scripts/bench_emulator_error.py [--cases NAME ...] [--points N]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import torch

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks.cases import make_problem  # noqa: E402
from benchmarks.catalog import CASES  # noqa: E402
from benchmarks.holdout import HOLDOUT  # noqa: E402
from torchshm.inference.adaptive.acquisition import design  # noqa: E402
from torchshm.inference.adaptive.field import FieldEmulator, model_transform  # noqa: E402
from torchshm.inference.adaptive.likelihood import EmulatedLogJoint, physical_columns  # noqa: E402

SMOKE = os.environ.get("TORCHSHM_SMOKE") == "1"  # tiny sizes: a check that it runs, no figures
ALL = {**CASES, **HOLDOUT}
#: (Latin hypercube runs, reference-posterior runs) of each design
DESIGNS = ((10, 0), (10, 10), (20, 10))
MODELS = ("diagonal", "independent", "correlated")


def _outputs(problem, theta_p: np.ndarray) -> np.ndarray:
    raw = torch.as_tensor(np.asarray(problem.model_outputs(theta_p)), dtype=torch.float64)
    return problem.at_measured(raw).numpy()


def _variances(log_joint: EmulatedLogJoint, rows: np.ndarray) -> tuple[np.ndarray, dict]:
    """Δ's three modelled variances at `B x D` rows, and the parts for the true error."""
    mean, var, theta = log_joint.parts(rows)
    _, grad = log_joint.gradient(mean, var, theta)
    data = log_joint.data_variance(mean, theta)
    valid = log_joint.valid.to(var.dtype)
    second = (0.5 * var.square() / data.square() * valid).sum((-1, -2))
    residual = torch.nan_to_num(log_joint.y - mean).square()
    diagonal = (var * residual / data.square() * valid).sum((-1, -2)) + second
    independent = (var * torch.nan_to_num(grad).square() * valid).sum((-1, -2)) + second
    correlated = log_joint.error_variance(mean, var, theta, grad)
    return {"diagonal": diagonal.numpy(), "independent": independent.numpy(),
            "correlated": correlated.numpy()}, {"mean": mean, "var": var, "theta": theta}


def emulators_at_designs(name: str, n_points: int, designs: tuple[tuple[int, int], ...], seed: int = 0):
    """Per design and test set of case ``name``: ``(problem, emulator, log_joint, runs, label,
    rows, strains)``, the emulator fitted to the design's runs, the test set's rows `T x D`
    inside the prior's support (σa, l, ... at the reference's mean) and the model's strains
    there `T x L x n` (module docstring: designs and test points)."""
    problem = make_problem(ALL[name])
    ref = json.loads((ROOT / "benchmarks" / "references" / f"{name}.json").read_text())
    names = list(problem.names)
    mean_ref = np.array([ref["mean"][ref["names"].index(n)] for n in names])
    sd_ref = np.array([ref["sd"][ref["names"].index(n)] for n in names])
    plausible = np.asarray(problem.plausible_bounds, dtype=np.float64)
    hard = np.asarray(problem.search_bounds, dtype=np.float64)
    physical = [names.index(n) for n in problem.physical_names if n in names]
    other = [i for i in range(len(names)) if i not in physical]
    for n_box, n_near in designs:
        rng = np.random.default_rng([seed, n_box, n_near])
        rows = np.concatenate([design(plausible, n_box, seed),
                               mean_ref + sd_ref * rng.standard_normal((n_near, len(names)))])
        theta_p = physical_columns(problem, np.clip(rows, hard[:, 0], hard[:, 1]))
        emulator = FieldEmulator.fit(
            theta_p, _outputs(problem, theta_p), torch.arange(problem.y.shape[1], dtype=torch.float64),
            torch.as_tensor(np.asarray(problem.measurements.loads, dtype=np.float64)),
            model_transform(problem.model))
        log_joint = EmulatedLogJoint(problem, emulator)
        width = plausible[:, 1] - plausible[:, 0]
        tests = {"far": plausible[:, 0] + rng.random((n_points, len(names))) * width,
                 "near": mean_ref + 2.0 * sd_ref * rng.standard_normal((n_points, len(names)))}
        for label, test in tests.items():
            test = np.clip(test, hard[:, 0], hard[:, 1])
            test[:, other] = mean_ref[other]  # σa, l, ... at the reference's mean
            test = test[np.isfinite(np.asarray(problem.log_prior(test), dtype=np.float64).reshape(-1))]
            true = torch.as_tensor(_outputs(problem, physical_columns(problem, test)))
            yield problem, emulator, log_joint, len(theta_p), label, test, true


def run_case(name: str, n_points: int, designs: tuple[tuple[int, int], ...],
             seed: int = 0) -> list[dict]:
    """Rows of z-score statistics for one case: one per design and test set."""
    out = []
    for problem, _, log_joint, runs, label, test, true in emulators_at_designs(name, n_points, designs, seed):
        variances, parts = _variances(log_joint, test)
        delta = (log_joint.at(true, parts["var"], parts["theta"])
                 - log_joint.at(parts["mean"], parts["var"], parts["theta"]))
        row = {"case": name, "P": len(problem.physical_names), "runs": runs,
               "test": label, "median_abs_delta": float(np.median(np.abs(delta)))}
        for model in MODELS:
            z = delta / np.sqrt(np.maximum(variances[model], 1e-300))
            z = z[np.isfinite(z)]
            row[model] = {"rms": float(np.sqrt(np.mean(z**2))) if z.size else float("nan"),
                          "p99": float(np.quantile(np.abs(z), 0.99)) if z.size else float("nan"),
                          "over3": float(np.mean(np.abs(z) > 3)) if z.size else float("nan")}
        out.append(row)
        print(f"{name:18s} {row['runs']:3d} runs {label:4s} median |Δ| {row['median_abs_delta']:9.3g} | "
              + " | ".join(f"{m} rms {row[m]['rms']:6.2f} >3: {row[m]['over3']:.2f}" for m in MODELS),
              flush=True)
    return out


def rows_of(run, description: str, points: int) -> list[dict]:
    """The command line shared by this script and its kin: ``--cases``, ``--points``, ``--out``
    and ``TORCHSHM_SMOKE=1``; ``run(name, points, designs)`` gives one case's rows."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--cases", nargs="+", default=list(ALL), choices=list(ALL))
    parser.add_argument("--points", type=int, default=points, help="test points per set")
    parser.add_argument("--out", help="JSON file of all rows")
    args = parser.parse_args()
    designs = DESIGNS
    if SMOKE:
        args.cases, args.points, designs = args.cases[:1], 10, DESIGNS[:1]
        print(f"TORCHSHM_SMOKE=1: {args.cases[0]}, one design, 10 points: a check that it runs")
    warnings.simplefilter("ignore")
    torch.set_num_threads(1)
    print(f"started {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, load average "
          + ", ".join(f"{x:.1f}" for x in os.getloadavg()))
    rows = [row for name in args.cases for row in run(name, args.points, designs)]
    if args.out:
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        Path(args.out).write_text(json.dumps(rows, indent=1))
    return rows


def main() -> None:
    rows = rows_of(run_case, __doc__.splitlines()[0], 150)
    print("\n| model | test points | median rms z | worst rms z (case, runs) | median share |z| > 3 | worst share |z| > 3 |")
    print("| --- | --- | ---: | --- | ---: | ---: |")
    for model in MODELS:
        for label in ("far", "near"):
            sel = [r for r in rows if r["test"] == label and np.isfinite(r[model]["rms"])]
            if not sel:
                continue
            worst = max(sel, key=lambda r: r[model]["rms"])
            print(f"| {model} | {label} | {statistics.median(r[model]['rms'] for r in sel):.2f} | "
                  f"{worst[model]['rms']:.2f} ({worst['case']}, {worst['runs']}) | "
                  f"{statistics.median(r[model]['over3'] for r in sel):.2f} | "
                  f"{max(r[model]['over3'] for r in sel):.2f} |")


if __name__ == "__main__":
    main()

"""Per round of ``method="emulator"`` on one benchmark case: the box exploration's unresolved points
under three readings of the emulator's uncertainty.

The exploration (``torchshm/inference/adaptive/explore.py``, step 6 of ``docs/inference.md``)
calls a Sobol point of the box unresolved when the upper bound ``μ + κ s`` of its emulated log
joint reaches the level ``best - gap``, with ``s`` the first-order sd of the log-likelihood that the
emulator's error causes there. For each round this script prints, beside the rule's own count:

- ``linear``: the points unresolved by that rule, before the posterior's flank is taken out;
- ``drawn``: how many of them stay unresolved when ``s`` and the mean come from Eq. (21)
  evaluated exactly at :data:`N_DRAWS` joint draws of the emulator's error (the error model of
  ``unsure.error_fields``, with the exploration's calibration): the mean of the drawn
  log joints plus ``κ`` times their sd still reaches the level;
- ``any``: how many of them have at least one drawn log joint at or above the level;
- ``second``: how many of them stay unresolved by an upper bound of the chance to reach the
  level from the curvature of Eq. (21) along the first-order direction
  (:func:`second_order_chance`: one more gradient per point, no draws), at the rule's
  ``Φ(-κ)``;
- ``flank``: the points the rule kept after its flank test (``beyond_posterior``), their
  distance ``m`` from the posterior's draws' mean in the draws' own covariance (all inferred
  parameters), and by how many nats their upper bound lies above the found mode's Gaussian tail
  ``max(log joint at the draws) - m²/2`` (negative: the tail explains the point).

The chain of rounds is the method's own (the script only reads what each round computed; the
extra draws use their own generator).

    OMP_NUM_THREADS=1 python scripts/trace_exploration.py fifth3_p6 [--options JSON]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import torch
from scipy.stats import norm

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import torchshm  # noqa: E402
from benchmarks.cases import make_problem  # noqa: E402
from benchmarks.holdout import KNOWN  # noqa: E402
from torchshm.inference.adaptive import explore as exploration  # noqa: E402
from torchshm.inference.adaptive import method  # noqa: E402
from torchshm.inference.adaptive.likelihood import EmulatedLogJoint  # noqa: E402
from torchshm.inference.adaptive.unsure import error_fields  # noqa: E402

#: joint draws of the emulator's error per round
N_DRAWS = 64


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("case", choices=list(KNOWN))
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--options", type=json.loads, default={}, metavar="JSON",
                        help='keyword options of method="emulator" (default: none)')
    args = parser.parse_args()
    torch.set_num_threads(1)
    rows: list[dict[str, float]] = []
    seen: dict[str, object] = {}
    explore, flank = exploration.explore, exploration.beyond_posterior

    def traced_explore(log_joint, best, columns, plausible, rng, calibration=1.0, *extra):
        scan = explore(log_joint, best, columns, plausible, rng, calibration, *extra)
        seen.update(log_joint=log_joint, calibration=calibration)
        rows.append(_drawn(log_joint, scan, calibration, len(rows)))
        return scan

    def traced_flank(scan, draws, columns, *extra):
        kept = flank(scan, draws, columns, *extra)
        rows[-1].update(_tail(seen["log_joint"], seen["calibration"], kept, draws))
        return kept

    method.explore, method.beyond_posterior = traced_explore, traced_flank
    problem = make_problem(KNOWN[args.case])
    cpu = time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        post = torchshm.identify(problem, method="emulator", seed=args.seed, **args.options)
    print("round   runs  rule  linear  drawn  any  second  flank  m (min/median/max)   above tail [nats]")
    for row, record in zip(post.diagnostics["rounds"], rows):
        m = record.get("m", (np.nan,) * 3)
        above = record.get("above", (np.nan,) * 3)
        print(f"{int(row['round']):5d} {int(row['n_emulator_runs']):6d} {int(row['n_unresolved']):5d} "
              f"{record['linear']:7d} {record['drawn']:6d} {record['any']:4d} {record.get('second', 0):7d} "
              f"{record.get('flank', 0):6d}"
              f"  {m[0]:5.1f} {m[1]:5.1f} {m[2]:5.1f}   {above[0]:6.1f} {above[1]:6.1f} {above[2]:6.1f}")
    print(f"converged {post.converged}, own CPU {time.process_time() - cpu:.1f} s (model and "
          f"this script's draws included)")


def whitened_distance(rows: np.ndarray, draws: np.ndarray) -> np.ndarray:
    """Mahalanobis distances `U` of rows `U x D` from the mean of draws `S x D`, in the draws'
    covariance."""
    cov = np.atleast_2d(np.cov(draws.T))
    factor = np.linalg.cholesky(cov + 1e-12 * np.diag(np.diag(cov)).clip(1e-300))
    return np.linalg.norm(np.linalg.solve(factor, (rows - draws.mean(0)).T), axis=0)


def _drawn(log_joint: EmulatedLogJoint, scan: exploration.Exploration, calibration: float,
           round_: int) -> dict[str, int]:
    """The unresolved points (before the flank test) by the exact Eq. (21) at drawn errors."""
    out = {"linear": scan.n_unresolved, "drawn": 0, "any": 0}
    if not scan.n_unresolved:
        return out
    mean, sd = log_joint.value_and_sd(scan.rows)
    scale = max(1.0, calibration)
    # the rule's level, from z = (μ - level) / (c s) at every point (one value)
    level = float(np.median(mean - scan.z * scale * np.maximum(sd, 1e-12)))
    inflated = EmulatedLogJoint(log_joint.problem, log_joint.emulator,
                                log_joint.inflation * scale**2)
    drawn = error_fields(inflated, scan.rows, N_DRAWS, np.random.default_rng([round_, 53]))
    centre, spread = drawn.mean(0), drawn.std(0)
    out["drawn"] = int(np.sum(centre + exploration.KAPPA * spread >= level))
    out["any"] = int(np.sum((drawn >= level).any(0)))
    chance = second_order_chance(inflated, scan.rows, level)
    out["second"] = int(np.sum(chance >= norm.sf(exploration.KAPPA)))
    return out


def second_order_chance(log_joint: EmulatedLogJoint, rows: np.ndarray, level: float,
                        n_alpha: int = 4000) -> np.ndarray:
    """`U` upper bounds of the chance that the log joint at rows `U x D` reaches ``level`` under
    the emulator's error model (``log_joint`` with its inflation), from the curvature of Eq.
    (21) along the first-order direction.

    In the error model ``δ = sqrt(v) ⊙ (E z)``, ``z`` `N` standard normals, Eq. (21) with σm = 0
    is a concave quadratic in ``z``: ``ℓ(z) = ℓ0 + aᵀz - ½ zᵀ H z``. With ``u = a / |a|``,
    ``α = uᵀz`` and ``β = (H u)ᵀ z``, Cauchy-Schwarz in the ``H`` inner product gives ``zᵀ H z >=
    β² / (uᵀ H u)``, so ``ℓ(z) <= ℓ0 + |a| α - β² / (2 uᵀ H u)``: a bound in two correlated
    normals, whose upper tail is one quadrature. ``H u`` is the gradient's change along ``δ(u)``
    (exact for a quadratic; with σm > 0 Eq. (21) is not quadratic and the bound is approximate).
    """
    mean, var, theta = log_joint.parts(rows)
    prior = np.asarray(log_joint.problem.log_prior(rows), dtype=np.float64).reshape(-1)
    basis = log_joint.emulator.error_basis  # m x N
    valid = log_joint.valid.to(var.dtype)
    sv = var.sqrt() * valid
    value, grad = log_joint.gradient(mean, torch.zeros_like(var), theta)
    a = (sv * torch.nan_to_num(grad)).flatten(1) @ basis  # U x N
    size = a.norm(dim=-1).clamp_min(1e-300)
    u = a / size[:, None]
    step = (sv.flatten(1) * (u @ basis.mT)).reshape(mean.shape)
    _, moved = log_joint.gradient(mean + step, torch.zeros_like(var), theta)
    h = (sv * torch.nan_to_num(grad - moved)).flatten(1) @ basis
    c = (u * h).sum(-1).clamp_min(0.0).numpy()
    hn = h.norm(dim=-1).clamp_min(1e-300).numpy()
    big = size.numpy()
    gap = level - (np.where(np.isfinite(value), value, -np.inf) + prior)  # nats to climb
    rho = np.clip(c / hn, -1.0, 1.0)
    other = np.sqrt(np.clip(1.0 - rho**2, 0.0, None))
    lo = np.minimum(gap / big, 8.0)
    alpha = lo[:, None] + np.linspace(0.0, 12.0, n_alpha)[None, :]  # U x G, where a α >= gap
    reach = 2.0 * c[:, None] * (big[:, None] * alpha - gap[:, None])  # β² must stay below it
    half = np.sqrt(np.clip(reach, 0.0, None)) / hn[:, None]
    centre = rho[:, None] * alpha
    with np.errstate(divide="ignore", invalid="ignore"):
        inner = np.where(other[:, None] > 1e-9,
                         norm.cdf((half - centre) / other[:, None]) - norm.cdf((-half - centre) / other[:, None]),
                         (np.abs(centre) <= half).astype(float))
    inner = np.where(reach >= 0.0, inner, 0.0)
    inner = np.where(c[:, None] > 1e-12, inner, (reach >= 0.0).astype(float))  # no curvature: first order
    chance = np.trapz(norm.pdf(alpha) * inner, alpha, axis=1)
    return np.where(np.isfinite(gap), np.clip(chance, 0.0, 1.0), 0.0)


def _tail(log_joint: EmulatedLogJoint, calibration: float, kept: exploration.Exploration,
          draws: np.ndarray) -> dict[str, object]:
    """Where the points kept by the flank test lie against the found mode's Gaussian."""
    if not kept.n_unresolved:
        return {"flank": 0}
    m = whitened_distance(kept.rows, draws)
    mean, sd = log_joint.value_and_sd(kept.rows)
    upper = mean + exploration.KAPPA * max(1.0, calibration) * sd
    above = upper - (float(np.max(log_joint(draws))) - 0.5 * m**2)
    quantiles = (0.0, 0.5, 1.0)
    return {"flank": kept.n_unresolved, "m": np.quantile(m, quantiles),
            "above": np.quantile(above, quantiles)}


if __name__ == "__main__":
    main()

"""Per round of ``method="emulator"`` on one benchmark case: the box exploration's unresolved points
under three readings of the emulator's uncertainty.

The exploration (``torchshm/inference/adaptive/explore.py``, step 6 of ``docs/inference.md``)
calls a Sobol point of the box unresolved when the upper bound ``μ + κ s`` of its emulated log
joint reaches the level ``best - gap``, with ``s`` the first-order sd of the log-likelihood that the
emulator's error causes there. For each round this script prints, beside the rule's own count:

- ``linear``: the points unresolved by the first-order bound, before the posterior's flank is
  taken out;
- ``drawn``: how many of them stay unresolved when ``s`` and the mean come from Eq. (21)
  evaluated exactly at :data:`N_DRAWS` joint draws of the emulator's error (the error model of
  ``unsure.error_fields``, with the exploration's calibration): the mean of the drawn
  log joints plus ``κ`` times their sd still reaches the level;
- ``any``: how many of them have at least one drawn log joint at or above the level;
- ``second``: how many of them stay unresolved by an upper bound of the chance to reach the
  level from the curvature of Eq. (21) along the first-order direction
  (``torchshm.inference.adaptive.curvature.reach_chance``, off in the rule: one more gradient
  per point, no draws), at the rule's ``Φ(-κ)``; ``missed``: of
  the points it rules out, those with a drawn log joint at the level;
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
from torchshm.inference.adaptive.curvature import reach_chance  # noqa: E402
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
    parser.add_argument("--second-order", action="store_true",
                        help="follow the second-order reading's open points (explore.SECOND_ORDER, off in the library)")
    args = parser.parse_args()
    torch.set_num_threads(1)
    rows: list[dict[str, float]] = []
    seen: dict[str, object] = {}
    explore, flank = exploration.explore, exploration.beyond_posterior

    def traced_explore(log_joint, best, columns, plausible, rng, calibration=1.0, *extra):
        scan = explore(log_joint, best, columns, plausible, rng, calibration, *extra)  # first order
        seen.update(log_joint=log_joint, calibration=calibration)
        record, keep = _drawn(log_joint, scan, calibration, len(rows))
        rows.append(record)
        if not args.second_order or keep is None:
            return scan
        return exploration.Exploration(scan.rows[keep], scan.z[keep], scan.margin, scan.top)

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
    print("round   runs  rule  linear  drawn  any  second  missed  flank  m (min/median/max)   above tail [nats]")
    for row, record in zip(post.diagnostics["rounds"], rows):
        m = record.get("m", (np.nan,) * 3)
        above = record.get("above", (np.nan,) * 3)
        print(f"{int(row['round']):5d} {int(row['n_emulator_runs']):6d} {int(row['n_unresolved']):5d} "
              f"{record['linear']:7d} {record['drawn']:6d} {record['any']:4d} {record.get('second', 0):7d} {record.get('missed', 0):7d} "
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
           round_: int) -> tuple[dict[str, int], np.ndarray | None]:
    """The unresolved points of the first-order bound (before the flank test) by the exact Eq.
    (21) at drawn errors and by the second-order reading, and which of them the latter keeps."""
    out = {"linear": scan.n_unresolved, "drawn": 0, "any": 0}
    if not scan.n_unresolved:
        return out, None
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
    chance = reach_chance(log_joint, scan.rows, level, calibration)
    keep = chance >= norm.sf(exploration.KAPPA)
    out["second"] = int(np.sum(keep))
    # points the bound rules out although a drawn exact log joint reached the level
    out["missed"] = int(np.sum(~keep & (drawn >= level).any(0)))
    return out, keep


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

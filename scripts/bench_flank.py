"""An experiment on the emulator's box exploration: the rule's flank test against a whitened one.

The exploration (``torchshm/inference/adaptive/explore.py``) leaves out an unresolved point of
the box when it lies within 3 sds of some posterior draw, the sds taken axis by axis
(``beyond_posterior``). In eight dimensions the points it keeps lie in the found mode's own
shell, where its tail crosses the exploration's level (``docs/benchmarks.md``, "The
exploration's open points in eight dimensions"). The variant ``whitened`` also leaves out a
point whose Mahalanobis distance from the draws' mean, in the draws' covariance over all `D`
inferred parameters, is below ``sqrt(chi2.ppf(1 - 1e-9, D))`` (6.9 for D = 4, 7.6 for D = 8:
the radius outside which a Gaussian posterior holds 1e-9 of its mass). It is not in
the library: this script patches it in for its own runs. The variant ``second_order`` keeps
the rule's flank test and reads the scan's open points again to second order
(``torchshm.inference.adaptive.curvature``, ``explore.SECOND_ORDER``, off in the library),
keeping those whose chance to reach the level is at least the rule's ``Φ(-κ)``.

Each (case, variant) runs the emulator with its defaults, as ``scripts/bench_identification.py``
does (one torch thread, scored against the case's reference), and prints one JSON row.

    OMP_NUM_THREADS=1 python scripts/bench_flank.py --variants rule whitened --cases beam3_bimodal
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
from scipy.stats import chi2

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))

import bench_identification  # noqa: E402
from benchmarks.holdout import KNOWN  # noqa: E402
from torchshm.inference.adaptive import explore as exploration  # noqa: E402
from torchshm.inference.adaptive import method  # noqa: E402
from trace_exploration import whitened_distance  # noqa: E402

#: tail mass outside the whitened flank's radius
TAIL = 1e-9
RULE = exploration.beyond_posterior
KEYS = ("case", "runs", "rounds", "max_dmean_sd", "sd_ratio_min", "sd_ratio_max", "dlog_z",
        "own_cpu_s", "converged")


def whitened(scan: exploration.Exploration, draws: np.ndarray, columns: list[int],
             *extra: float) -> exploration.Exploration:
    """The rule's flank test, then the points within the whitened radius left out too."""
    kept = RULE(scan, draws, columns, *extra)
    dim = draws.shape[1]
    if not kept.n_unresolved or draws.shape[0] < 3 * dim:
        return kept
    outside = whitened_distance(kept.rows, draws) > np.sqrt(chi2.ppf(1.0 - TAIL, dim))
    return exploration.Exploration(kept.rows[outside], kept.z[outside], kept.margin, kept.top)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="+", required=True, choices=list(KNOWN))
    parser.add_argument("--variants", nargs="+", default=["rule", "whitened"], choices=["rule", "whitened", "second_order"])
    parser.add_argument("--options", type=json.loads, default={}, metavar="JSON",
                        help='keyword options of method="emulator" (default: none)')
    parser.add_argument("--seeds", nargs="+", type=int, default=[0], help="seeds of the runs (default: 0)")
    args = parser.parse_args()
    for case in args.cases:
        for seed in args.seeds:
            for variant in args.variants:
                method.beyond_posterior = whitened if variant == "whitened" else RULE
                exploration.SECOND_ORDER = variant == "second_order"
                row = bench_identification.run_task((case, "emulator", False, seed, args.options))
                print("ROW", json.dumps({"variant": variant, "seed": seed, **{k: row.get(k) for k in KEYS}}),
                      flush=True)
    method.beyond_posterior, exploration.SECOND_ORDER = RULE, False


if __name__ == "__main__":
    main()

"""Per-round stop-rule terms of ``method="emulator"`` on one benchmark case.

Runs the emulator with its defaults on a case of the suite or of a held-out set and prints, per
round, the terms its stop rule reads (``diagnostics["rounds"]``; ``docs/inference.md`` step 7):
runs so far, TV to the previous round, the witness, the emulator's log-likelihood sd over the
posterior, the log evidence's sd over joint draws of the emulator (where the rule needed it),
how far the last batch was off, the batch check's calibration, the unresolved points
of the box, the exploration's calibration, the share of draws at the runs' edge, the modes, and
whether the posterior had settled, and (with a reference) how far the round's posterior means
of the physical parameters lie from the reference's, in its sds; then the result beside it.

    OMP_NUM_THREADS=1 python scripts/trace_emulator.py holdout3_p2 [--seed 0]
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

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import torchshm  # noqa: E402
from benchmarks.cases import make_problem  # noqa: E402
from benchmarks.holdout import KNOWN  # noqa: E402

#: (row key, column title) of the printed table
COLUMNS = (("n_emulator_runs", "runs"), ("tv", "TV"), ("tv_witness", "witness"),
           ("emulator_loglik_sd", "sd"), ("evidence_sd", "log Z sd"), ("check_loglik_error", "batch off"),
           ("emulator_inflation", "inflation"), ("n_unresolved", "unresolved"),
           ("explore_calibration", "explore c"), ("edge_runs", "edge"), ("n_modes", "modes"),
           ("settled", "settled"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("case", choices=list(KNOWN))
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--options", type=json.loads, default={}, metavar="JSON",
                        help='keyword options of method="emulator" (default: none)')
    args = parser.parse_args()
    torch.set_num_threads(1)
    problem = make_problem(KNOWN[args.case])
    cpu = time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        post = torchshm.identify(problem, method="emulator", seed=args.seed, **args.options)
    path = ROOT / "benchmarks" / "references" / f"{args.case}.json"
    ref = json.loads(path.read_text()) if path.exists() else None
    print("round " + " ".join(f"{title:>10}" for _, title in COLUMNS) + ("  off [ref sd]" if ref else ""))
    for row in post.diagnostics["rounds"]:
        line = f"{int(row['round']):5d} " + " ".join(f"{row.get(key, np.nan):10.3g}" for key, _ in COLUMNS)
        if ref is not None:  # the round's posterior means against the reference's, in its sds
            off = [abs(row[f"{n}/mean"] - ref["mean"][j]) / ref["sd"][j] for j, n in enumerate(ref["names"])
                   if n in problem.physical_names and f"{n}/mean" in row]
            line += f"  {max(off, default=np.nan):12.3g}"
        print(line)
    print(f"converged {post.converged}, own CPU {time.process_time() - cpu:.1f} s (model included)")
    draws = np.asarray(post.samples)
    for i, name in enumerate(post.names):
        line = f"{name:>12}: {draws[:, i].mean():.4g} ± {draws[:, i].std():.3g}"
        if ref is not None and name in ref["names"]:
            j = ref["names"].index(name)
            line += f"   reference {ref['mean'][j]:.4g} ± {ref['sd'][j]:.3g}"
        print(line)


if __name__ == "__main__":
    main()

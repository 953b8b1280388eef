"""An experiment on the emulator's early rounds: batches drawn where the emulator's possible
errors put the posterior, not only where its mean puts it.

In the first rounds the plug-in posterior (Eq. (21) at the emulator's mean) can lie many
reference sds from the truth while being narrow (the traces of ``fifth0_p2`` and
``fifth1_p3``: 15 and 29 sds off at the design), so the next batch, drawn from it, lands in
the wrong place and the zoom towards the posterior takes rounds. The variant ``averaged``
replaces a round's posterior draws, while the emulator's first-order log-likelihood sd over
them exceeds ``--above`` nats (default 1), by draws of the posterior averaged over joint draws
of the emulator's error (``torchshm.inference.adaptive.unsure.average_over_errors``, with
``--fields`` draws): a batch from it is spread over where the truth may lie, as in Thompson
sampling. Such a round cannot end the run (its sd is above the stop rule's ``sd_tol``), so
the stop rule is untouched. It is not in the library: this script patches it in for its own
runs (``sampling.run_chain`` as the method calls it).

Each (case, variant) runs the emulator with its defaults, as ``scripts/bench_identification.py``
does (one torch thread, scored against the case's reference), and prints one JSON row.

    OMP_NUM_THREADS=1 python scripts/bench_early_batch.py --variants plug-in averaged --cases fifth0_p2
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))

import bench_identification  # noqa: E402
from benchmarks.holdout import KNOWN  # noqa: E402
from torchshm.inference.adaptive import method, sampling  # noqa: E402
from torchshm.inference.adaptive.likelihood import EmulatedLogJoint  # noqa: E402
from torchshm.inference.adaptive.unsure import average_over_errors  # noqa: E402

KEYS = ("case", "runs", "rounds", "max_dmean_sd", "sd_ratio_min", "sd_ratio_max", "dlog_z",
        "own_cpu_s", "converged")
CHAIN = sampling.run_chain


def averaged_chain(above: float, fields: int):
    """``sampling.run_chain`` whose samples are replaced, while the emulator is unsure by more
    than ``above`` nats over them, by the posterior averaged over ``fields`` error draws."""

    def run_chain(log_joint, start, n_steps, seed, hop=False):
        samples, last = CHAIN(log_joint, start, n_steps, seed, hop)
        if not isinstance(log_joint, EmulatedLogJoint) or samples.shape[0] < 10:
            return samples, last
        rng = np.random.default_rng([seed, 71])
        some = samples[rng.choice(samples.shape[0], min(600, samples.shape[0]), replace=False)]
        _, sd = log_joint.emulator_share(some)
        if float(sd.mean()) <= above:
            return samples, last
        problem = log_joint.problem
        out = average_over_errors(log_joint, some, np.asarray(problem.search_bounds, dtype=float),
                                  np.asarray(problem.plausible_bounds, dtype=float),
                                  samples.shape[0], seed, fields)
        return (samples if out is None else out.draws), last

    return run_chain


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="+", required=True, choices=list(KNOWN))
    parser.add_argument("--variants", nargs="+", default=["plug-in", "averaged"],
                        choices=["plug-in", "averaged"])
    parser.add_argument("--above", type=float, default=1.0, help="sd [nats] above which (default 1)")
    parser.add_argument("--fields", type=int, default=8, help="error draws (default 8)")
    parser.add_argument("--options", type=json.loads, default={}, metavar="JSON",
                        help='keyword options of method="emulator" (default: none)')
    args = parser.parse_args()
    for case in args.cases:
        for variant in args.variants:
            method.sampling.run_chain = (averaged_chain(args.above, args.fields)
                                         if variant == "averaged" else CHAIN)
            row = bench_identification.run_task((case, "emulator", False, 0, args.options))
            print("ROW", json.dumps({"variant": variant, **{k: row.get(k) for k in KEYS}}), flush=True)
    method.sampling.run_chain = CHAIN


if __name__ == "__main__":
    main()

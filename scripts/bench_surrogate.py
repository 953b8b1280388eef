"""Time the shipped surrogate: loading, and predictions for a batch of parameter vectors.

    python scripts/bench_surrogate.py [--batch 1000] [--repeats 7]

Prints the median and the range over the repeats, in seconds, with the number of threads
torch uses (set OMP_NUM_THREADS to compare).
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from typing import Callable

import torch

from torchshm.casestudy import PRIOR_BOX, bridge705_surrogate
from torchshm.surrogate import uniform_in_box


SMOKE = os.environ.get("TORCHSHM_SMOKE") == "1"  # tiny sizes: a check that it runs (docs test), no figures


def timed(action: Callable[[], object], repeats: int) -> list[float]:
    """Wall times [s] of ``repeats`` calls of ``action`` (after one warm-up call)."""
    action()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        action()
        times.append(time.perf_counter() - start)
    return times


def report(label: str, times: list[float]) -> None:
    print(f"{label:44s} median {statistics.median(times):.4f} s "
          f"(min {min(times):.4f}, max {max(times):.4f}, {len(times)} repeats)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--batch", type=int, default=1000)
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    if SMOKE:
        args.batch, args.repeats = min(args.batch, 50), min(args.repeats, 2)
        print("TORCHSHM_SMOKE=1: batch 50, 2 repeats, a check that the script runs, not a benchmark")
    print(f"torch {torch.__version__}, {torch.get_num_threads()} threads")
    report("load bridge705_surrogate()", timed(bridge705_surrogate, args.repeats))
    sur = bridge705_surrogate()
    theta = uniform_in_box(args.batch, PRIOR_BOX, seed=0)
    with torch.no_grad():
        report(f"mean, batch {args.batch}", timed(lambda: sur(theta), args.repeats))
        report(f"mean + variance, batch {args.batch}",
               timed(lambda: sur.predict(theta), args.repeats))
    grad_theta = theta.clone().requires_grad_(True)
    report(f"mean + gradient of the sum, batch {args.batch}",
           timed(lambda: torch.autograd.grad(sur(grad_theta).sum(), grad_theta), args.repeats))


if __name__ == "__main__":
    main()

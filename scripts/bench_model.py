"""Time the bridge 705 model: construction, one parameter vector, a batch of 64.

Prints medians over repeated runs (wall time, ``time.perf_counter``).

Usage: ``python scripts/bench_model.py [--repeats N]``
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from typing import Callable

import torch

from torchshm.casestudy import bridge705
from torchshm.casestudy.model import _operators


SMOKE = os.environ.get("TORCHSHM_SMOKE") == "1"  # tiny sizes: a check that it runs (docs test), no figures


def median_time(call: Callable[[], object], repeats: int) -> float:
    """Median wall time [s] of `repeats` calls (after one warm-up call)."""
    call()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        call()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def construct() -> None:
    _operators.cache_clear()
    bridge705()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=200)
    args = parser.parse_args()
    if SMOKE:
        args.repeats = min(args.repeats, 3)
        print("TORCHSHM_SMOKE=1: 3 repeats, a check that the script runs, not a benchmark")

    model = bridge705()
    one = torch.tensor([35.0, 11.5])
    generator = torch.Generator().manual_seed(0)
    batch = torch.rand(64, 2, generator=generator) * torch.tensor([90.0, 12.0]) + torch.tensor([10.0, 0.0])
    batch_grad = batch.clone().requires_grad_(True)

    def forward_backward() -> None:
        (grad,) = torch.autograd.grad(model(batch_grad).sum(), batch_grad)

    print(f"torch {torch.__version__}, {torch.get_num_threads()} threads")
    print(f"construction of bridge705() (no cache): median {median_time(construct, 5):.3f} s")
    print(f"construction of bridge705() (cached operators): median {1e3 * median_time(bridge705, 20):.3f} ms")
    with torch.no_grad():
        t_one = median_time(lambda: model(one), args.repeats)
        t_batch = median_time(lambda: model(batch), args.repeats)
    print(f"one parameter vector (12 x 351 strains): median {1e6 * t_one:.1f} µs")
    print(f"batch of 64 parameter vectors: median {1e3 * t_batch:.3f} ms")
    print(f"batch of 64, forward + gradient: median {1e3 * median_time(forward_backward, 50):.3f} ms")


if __name__ == "__main__":
    main()

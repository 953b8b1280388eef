"""Benchmark of the exact lattice form of Eq. (21) (kernel ``separable_exponential`` on a grid).

One parameter vector, one load case, on a `side x side` grid of the unit square with 10 % of
the nodes masked at random (holes; the corners kept): σa = 1 µε, σe = 0.1 µε, η uniform in
20..100 µε, σm 0 and 0.05, l = 0.02, 0.2 and 1 × the field (1 m); ``y`` is η plus one exact
predictive draw. Each (size, l, σm) runs in a fresh process, one thread (``OMP_NUM_THREADS=1``,
``torch.set_num_threads(1)``): CPU time (``time.process_time``) and wall time of

- the first call of ``torchshm.log_likelihood`` (``method="auto"``, which takes the lattice
  form; it reads the grid and orders its nodes, cached per grid shape), and of a second call;
- one predictive draw (``torchshm.predictive.predictive_draws``);
- at 10^4 points, beside them, the dense path (``method="dense"``) and the difference;

and the peak memory growth (``VmHWM`` after the calls minus the resident set before them).
``--sides`` picks the sizes (default 100, 316, 1000: 10^4, 10^5, 10^6 nodes); ``--sigma-e`` and
``--sigma-m`` the noise (``--sigma-e 0 --sigma-m 0``: every reading exact, the form that fixes
the field at the observed nodes and integrates the holes).

Usage (from the repository root)::

    PYTHONPATH=. OMP_NUM_THREADS=1 python scripts/bench_likelihood_lattice.py [--sides 100,316,1000]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time

import numpy as np
import torch

import torchshm
from torchshm.predictive import predictive_draws

SA, SE = 1.0, 0.1
LENGTHS = (0.02, 0.2, 1.0)
SIGMA_M = (0.0, 0.05)


def field(side: int, seed: int) -> np.ndarray:
    """`n x 2` nodes [m] of a `side x side` grid of the unit square, 10 % masked (corners kept)."""
    g = np.linspace(0.0, 1.0, side)
    x = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)
    keep = np.random.default_rng(seed).random(len(x)) > 0.1
    keep[[0, side - 1, -side, -1]] = True
    return x[keep]


def _rss(field_name: str) -> int:
    with open("/proc/self/status") as f:
        return int(next(row for row in f if row.startswith(field_name)).split()[1]) * 1024


def _timed(call):
    cpu, wall = time.process_time(), time.perf_counter()
    out = call()
    return out, time.process_time() - cpu, time.perf_counter() - wall


def one(side: int, length: float, sigma_m: float, seed: int, sigma_e: float = SE) -> None:
    """(child) one size, length, σm and σe: tab-separated rows ``label, CPU, wall, value``."""
    torch.set_num_threads(1)
    small = torch.tensor(field(12, seed))  # warm-up of the code paths (imports, first calls)
    torchshm.log_likelihood(torch.ones(1, len(small)), torch.ones(1, 1, len(small)), small,
                            "separable_exponential", SA, length, sigma_m, sigma_e)
    x = torch.tensor(field(side, seed))
    n = x.shape[0]
    eta = torch.tensor(np.random.default_rng(seed + 1).uniform(20.0, 100.0, (1, 1, n)))
    before = _rss("VmRSS:")
    gen = torch.Generator().manual_seed(seed)
    draw, cpu, wall = _timed(lambda: predictive_draws(eta, x, "separable_exponential", torch.tensor([SA]),
                                                      torch.tensor([length]), sigma_m, sigma_e, gen))
    print(f"draw\t{cpu}\t{wall}\tnan")
    y = draw[0]

    def call(method: str = "auto") -> float:
        return float(torchshm.log_likelihood(y, eta, x, "separable_exponential", SA, length, sigma_m, sigma_e, method=method))

    value, cpu, wall = _timed(call)
    print(f"first\t{cpu}\t{wall}\t{value}")
    again, cpu, wall = _timed(call)
    print(f"second\t{cpu}\t{wall}\t{again}")
    grow = _rss("VmHWM:") - before
    if n <= 20_000:
        dense, cpu, wall = _timed(lambda: call("dense"))
        print(f"dense\t{cpu}\t{wall}\t{dense}")
    print(f"memory\t{grow}")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sides", default="100,316,1000")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--sigma-e", type=float, default=SE, help="noise sd [µε] (default 0.1)")
    parser.add_argument("--sigma-m", default=",".join(map(str, SIGMA_M)), help="σm values (default 0,0.05)")
    parser.add_argument("--one", default="", help=argparse.SUPPRESS)  # side,length,sigma_m (child)
    args = parser.parse_args(argv)
    if args.one:
        side, length, sigma_m = args.one.split(",")
        one(int(side), float(length), float(sigma_m), args.seed, args.sigma_e)
        return
    print(f"uptime: {os.getloadavg()} (1, 5, 15 min load averages); {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; "
          f"σe = {args.sigma_e} µε")
    print("| n (side², 10 % holes) | l [m] | σm | first call CPU [s] | next call CPU [s] | next call wall [s] "
          "| draw CPU [s] | peak memory growth [MB] | dense CPU [s] | lattice − dense [nat] |")
    print("| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for side in (int(s) for s in args.sides.split(",")):
        for length in LENGTHS:
            for sigma_m in (float(v) for v in args.sigma_m.split(",")):
                out = subprocess.run([sys.executable, __file__, "--one", f"{side},{length},{sigma_m}",
                                      "--seed", str(args.seed), "--sigma-e", str(args.sigma_e)],
                                     check=True, capture_output=True, text=True)
                rows = {line.split("\t")[0]: line.split("\t")[1:] for line in out.stdout.strip().splitlines()}
                n = len(field(side, args.seed))
                dense = rows.get("dense")
                tail = (f"{float(dense[0]):.3f} | {float(rows['second'][2]) - float(dense[2]):.1e}" if dense else "– | –")
                print(f"| {n:,} | {length} | {sigma_m} | {float(rows['first'][0]):.3f} | {float(rows['second'][0]):.3f} "
                      f"| {float(rows['second'][1]):.3f} | {float(rows['draw'][0]):.3f} "
                      f"| {int(rows['memory'][0]) / 2**20:.0f} | {tail} |", flush=True)
    print(f"uptime after: {os.getloadavg()}")


if __name__ == "__main__":
    main()

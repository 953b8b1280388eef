"""Benchmark of the likelihood of Eq. (21) at the sizes of sub-cases C1 and B.

Compares, for one parameter vector,

(a) what a user would write first: one dense `L n x L n` covariance and
    ``scipy.stats.multivariate_normal.logpdf``;
(b) a dense torch Cholesky factorisation of the same `L n x L n` matrix;
(c) :func:`torchshm.log_likelihood` (block-diagonal: `L` Cholesky factorisations of `n x n`);

and (d) :func:`torchshm.log_likelihood` for a batch of 40 parameter vectors (time per vector).
Kernel ``matern32``, sigma_m = 0.05, sigma_e = 0.1 µε, positions 35.0..70.0 m every 0.1 m.
Prints a markdown table of median wall times. The thread count of both numpy's BLAS and torch
follows the environment (e.g. ``OMP_NUM_THREADS=1``).

Then the O(n) state-space form (``docs/likelihood.md``):

- crossover: dense and state-space times at n = 500 .. 3,000 points, 1 and 12 load cases;
- n = 10^5 points x 12 load cases, one parameter vector, the three Markov kernels, beside
  celerite2's exact exponential kernel (``RealTerm``) on the same positions, residuals and
  heteroscedastic diagonals (celerite2 is a benchmark-only dependency, imported only here);
- predictive draws of the discrepancy, 2,000 x 4 load cases x 7,001 positions (0.005 m);
- n = 10^3 .. 10^6 in one load case (``matern32``): time and peak memory growth (peak resident
  set during the call minus the resident set before it), each size in a fresh subprocess.

2-D fields (the full-scale and Vecchia forms): ``--only-field`` runs ``scripts/bench_likelihood_field.py``
(error against the dense path over the priors' range; 10^4 .. 10^6 points, one parameter
vector, one load case, beside the dense path, scikit-learn's exact GP and a numpy reference);
``--only-lattice`` runs ``scripts/bench_likelihood_lattice.py`` (the exact lattice form of kernel
``separable_exponential`` on a grid with holes, 10^4 .. 10^6 points, beside the dense path at 10^4);
``--only-keops`` runs ``scripts/bench_likelihood_keops.py`` (10^3 .. 10^5 points beside GPyTorch's
exact Cholesky and its BBMM with KeOps kernels; its KeOps rows are skipped, with the reason,
without pykeops or with ``TORCHSHM_SMOKE=1``).

Usage::

    python scripts/bench_likelihood.py [--repeats 20] [--slow-repeats 3] [--seed 0]
        [--only-dense | --only-scaling | --only-celerite | --only-draws | --only-field | --only-lattice
         | --only-keops]
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import torch
from scipy import linalg, stats

import torchshm

SIGMA_M, SIGMA_E, SIGMA_A, LENGTH, BATCH = 0.05, 0.1, 0.9, 2.0, 40


SMOKE = os.environ.get("TORCHSHM_SMOKE") == "1"  # tiny sizes: a check that it runs (docs test), no figures


def naive_scipy(y: np.ndarray, eta: np.ndarray, x: np.ndarray) -> float:
    """(a) Full block-diagonal covariance in numpy, density by scipy."""
    r = np.sqrt(3.0) * np.abs(x[:, None] - x[None, :]) / LENGTH
    k = SIGMA_A**2 * (1.0 + r) * np.exp(-r)
    blocks = [np.diag(SIGMA_M**2 * e**2 + SIGMA_E**2) + k for e in eta]
    cov = linalg.block_diag(*blocks)
    return float(stats.multivariate_normal.logpdf(y.ravel(), eta.ravel(), cov))


def dense_torch(y: torch.Tensor, eta: torch.Tensor, x: torch.Tensor) -> float:
    """(b) Full block-diagonal covariance in torch, one dense Cholesky factorisation."""
    r = 3.0**0.5 * (x[:, None] - x[None, :]).abs() / LENGTH
    k = SIGMA_A**2 * (1.0 + r) * torch.exp(-r)
    cov = torch.block_diag(*[torch.diag(SIGMA_M**2 * e**2 + SIGMA_E**2) + k for e in eta])
    chol = torch.linalg.cholesky(cov)
    z = torch.linalg.solve_triangular(chol, (y - eta).reshape(-1, 1), upper=False)
    log_det = 2.0 * chol.diagonal().log().sum()
    return float(-0.5 * (z.square().sum() + log_det + cov.shape[0] * np.log(2.0 * np.pi)))


def median_seconds(fn: Callable[[], object], repeats: int) -> tuple[float, float, object]:
    """Median wall and CPU seconds over ``repeats`` calls after a warm-up call; last result."""
    result = fn()
    wall, cpu = [], []
    for _ in range(repeats):
        start, start_cpu = time.perf_counter(), time.process_time()
        result = fn()
        wall.append(time.perf_counter() - start)
        cpu.append(time.process_time() - start_cpu)
    return statistics.median(wall), statistics.median(cpu), result


@dataclass
class Row:
    """One line of the table: median seconds per parameter vector (wall and CPU)."""

    size: str
    method: str
    wall: float
    cpu: float
    value: float


def bench_size(label: str, n_loads: int, args: argparse.Namespace) -> list[Row]:
    """Rows (a) to (d) for `n_loads` load cases of 351 points (no (d) for one load case)."""
    rng = np.random.default_rng(args.seed)
    x = np.round(35.0 + 0.1 * np.arange(351), 10)
    eta = 50.0 * np.sin(x[None, :] / 3.0 + rng.uniform(0, 6, (n_loads, 1)))
    y = eta + rng.normal(0.0, 1.0, eta.shape)
    yt, etat, xt = (torch.as_tensor(a) for a in (y, eta, x))
    size = f"{label} ({n_loads} x 351 = {n_loads * 351} points)"

    def ours(e: torch.Tensor, s: object, ell: object) -> torch.Tensor:
        return torchshm.log_likelihood(yt, e, xt, "matern32", s, ell, SIGMA_M, SIGMA_E)

    cases: list[tuple[str, Callable[[], object], int, int]] = [
        (
            "(a) scipy `multivariate_normal.logpdf`, dense",
            lambda: naive_scipy(y, eta, x),
            args.slow_repeats,
            1,
        ),
        ("(b) torch dense Cholesky", lambda: dense_torch(yt, etat, xt), args.slow_repeats, 1),
        ("(c) `torchshm.log_likelihood`", lambda: ours(etat, SIGMA_A, LENGTH), args.repeats, 1),
    ]
    if n_loads > 1:
        batch = etat.expand(BATCH, -1, -1)
        s, ell = torch.full((BATCH,), SIGMA_A), torch.full((BATCH,), LENGTH)
        cases.append(
            (
                f"(d) `torchshm.log_likelihood`, batch of {BATCH}",
                lambda: ours(batch, s, ell),
                max(3, args.repeats // 4),
                BATCH,
            )
        )
    rows = []
    for method, fn, repeats, vectors in cases:
        wall, cpu, value = median_seconds(fn, repeats)
        first = float(torch.as_tensor(value, dtype=torch.float64).reshape(-1)[0])
        rows.append(Row(size, method, wall / vectors, cpu / vectors, first))
    return rows


def dense_data(n: int, n_loads: int, seed: int) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Positions (35..70 m, irregular), measurements `L x n` and model responses `L x n`."""
    rng = np.random.default_rng(seed)
    x = np.sort(rng.uniform(35.0, 70.0, n))
    eta = 50.0 * np.sin(x[None, :] / 3.0 + rng.uniform(0, 6, (n_loads, 1)))
    y = eta + rng.normal(0.0, 1.0, eta.shape)
    return torch.as_tensor(x), torch.as_tensor(y), torch.as_tensor(eta)


def crossover(args: argparse.Namespace) -> None:
    """Dense vs state-space `torchshm.log_likelihood`, one parameter vector (matern32)."""
    print("\n| points per load case | load cases | dense [ms] | state space [ms] |")
    print("| ---: | ---: | ---: | ---: |")
    for n_loads, sizes in ((1, (250, 500, 1000, 2000)), (12, (250, 500, 1000))):
        for n in sizes:
            x, y, eta = dense_data(n, n_loads, args.seed)
            times = []
            for method in ("dense", "state_space"):
                fn = lambda: torchshm.log_likelihood(y, eta, x, "matern32", SIGMA_A, LENGTH, SIGMA_M, SIGMA_E, method=method)  # noqa: E731,B023
                times.append(median_seconds(fn, 1)[0])
            print(f"| {n} | {n_loads} | {1e3 * times[0]:.4g} | {1e3 * times[1]:.4g} |")


def against_celerite(args: argparse.Namespace, n: int = 100_000, n_loads: int = 12) -> None:
    """n x 12 load cases, one parameter vector: the three kernels and celerite2's RealTerm."""
    import celerite2  # benchmark-only dependency

    x, y, eta = dense_data(n, n_loads, args.seed)
    noise = (SIGMA_M**2 * eta.square() + SIGMA_E**2).numpy()
    resid = (y - eta).numpy()

    def celerite_exponential() -> float:
        term = celerite2.terms.RealTerm(a=SIGMA_A**2, c=1.0 / LENGTH)
        total = 0.0
        for r_l, d_l in zip(resid, noise):
            gp = celerite2.GaussianProcess(term, mean=0.0)
            gp.compute(x.numpy(), diag=d_l, check_sorted=False)
            total += gp.log_likelihood(r_l)
        return total

    wall_ref, cpu_ref, ref = median_seconds(celerite_exponential, args.slow_repeats)
    print(f"\nn = {n:,} x {n_loads} load cases, one parameter vector (median of {args.slow_repeats}):\n")
    print("| method | wall [s] | CPU [s] | ÷ celerite2, wall | ÷ celerite2, CPU | value |")
    print("| --- | ---: | ---: | ---: | ---: | ---: |")
    print(f"| celerite2 `RealTerm` (exact exponential), C++ | {wall_ref:.3f} | {cpu_ref:.3f} | 1x | 1x | {ref:.6f} |")
    for kernel in ("exponential", "matern32", "matern52"):
        fn = lambda: torchshm.log_likelihood(y, eta, x, kernel, SIGMA_A, LENGTH, SIGMA_M, SIGMA_E)  # noqa: E731,B023
        with torch.no_grad():
            wall, cpu, value = median_seconds(fn, args.slow_repeats)
        print(
            f"| `torchshm.log_likelihood`, {kernel} | {wall:.3f} | {cpu:.3f} | {wall / wall_ref:.2f}x "
            f"| {cpu / cpu_ref:.2f}x | {float(value):.6f} |"
        )


def draws(args: argparse.Namespace, n_draws: int = 2000, n_loads: int = 4) -> None:
    """Predictive draws of the discrepancy at the 0.005 m pitch (7,001 positions), the
    posterior predictive's size: `n_draws` parameter vectors x `n_loads` load cases."""
    from torchshm.kernels import get_kernel
    from torchshm.likelihood import statespace

    x = torch.round(35.0 + 0.005 * torch.arange(7001, dtype=torch.float64), decimals=10)
    sigma_a = torch.full((n_draws,), SIGMA_A, dtype=torch.float64)
    length = torch.full((n_draws,), LENGTH, dtype=torch.float64)
    print(f"\nState-space draws, {n_draws:,} x {n_loads} load cases x 7,001 positions (one call each):\n")
    print("| kernel | wall [s] | CPU [s] | sample variance / σa² |")
    print("| --- | ---: | ---: | ---: |")
    for kernel in ("exponential", "matern32", "matern52"):
        fn = lambda: statespace.sample(x, get_kernel(kernel), sigma_a, length, n_loads, torch.Generator().manual_seed(args.seed))  # noqa: E731,B023
        start, start_cpu = time.perf_counter(), time.process_time()
        f = fn()
        wall, cpu = time.perf_counter() - start, time.process_time() - start_cpu
        print(f"| {kernel} | {wall:.2f} | {cpu:.2f} | {float(f.var()) / SIGMA_A**2:.4f} |")


def _rss_bytes() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def _peak_rss_bytes() -> int:
    """High-water mark of this process's resident set (``VmHWM``; unlike ``ru_maxrss`` it does
    not include the parent's resident set at the fork)."""
    with open("/proc/self/status") as f:
        line = next(row for row in f if row.startswith("VmHWM:"))
    return int(line.split()[1]) * 1024


def one_size(n: int, seed: int) -> None:
    """(child process) time and peak memory growth of one call at n points, one load case."""
    x, y, eta = dense_data(200, 1, seed)
    with torch.no_grad():  # warm-up: first-call initialisation is not part of the growth
        torchshm.log_likelihood(y, eta, x, "matern32", SIGMA_A, LENGTH, SIGMA_M, SIGMA_E, method="state_space")
    x, y, eta = dense_data(n, 1, seed)
    before = _rss_bytes()
    start = time.perf_counter()
    with torch.no_grad():
        torchshm.log_likelihood(y, eta, x, "matern32", SIGMA_A, LENGTH, SIGMA_M, SIGMA_E)
    wall = time.perf_counter() - start
    peak = _peak_rss_bytes()
    print(f"{wall} {max(0, peak - before)}")


def scaling(args: argparse.Namespace) -> None:
    """n = 10^3 .. 10^6, one load case, one fresh subprocess per size."""
    print("\n| n (one load case, matern32) | wall [s] | peak memory growth [MB] | per point [µs] |")
    print("| ---: | ---: | ---: | ---: |")
    for n in (1_000, 10_000, 100_000, 1_000_000):
        out = subprocess.run(
            [sys.executable, __file__, "--one-size", str(n), "--seed", str(args.seed)],
            check=True, capture_output=True, text=True,
        ).stdout.split()
        wall, grow = float(out[-2]), int(out[-1])
        print(f"| {n:,} | {wall:.3f} | {grow / 2**20:.0f} | {1e6 * wall / n:.2f} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=20, help="timed calls of the fast methods")
    parser.add_argument("--slow-repeats", type=int, default=3, help="timed calls of (a) and (b)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--only-dense", action="store_true", help="only the O(n) (dense fibre) part")
    parser.add_argument("--only-scaling", action="store_true", help="only n = 10^3 .. 10^6")
    parser.add_argument("--only-celerite", action="store_true", help="only n = 10^5 x 12 beside celerite2")
    parser.add_argument("--only-draws", action="store_true", help="only the O(n) predictive draws")
    parser.add_argument("--only-field", action="store_true", help="only the 2-D fields (full-scale and Vecchia forms)")
    parser.add_argument("--only-lattice", action="store_true", help="only the lattice form (separable kernel on a grid)")
    parser.add_argument("--only-keops", action="store_true", help="only the 2-D field beside GPyTorch (Cholesky, BBMM + KeOps)")
    parser.add_argument("--one-size", type=int, default=0, help=argparse.SUPPRESS)
    args = parser.parse_args()
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    if args.only_field:
        import bench_likelihood_field

        bench_likelihood_field.main(["--seed", str(args.seed)])
        return
    if args.only_lattice:
        import bench_likelihood_lattice

        bench_likelihood_lattice.main(["--seed", str(args.seed)])
        return
    if args.only_keops or SMOKE:  # the smoke: 144 points, KeOps rows skipped with their reason
        import bench_likelihood_keops

        bench_likelihood_keops.main(["--seed", str(args.seed)])
        if args.only_keops:
            return
    if args.one_size:
        one_size(args.one_size, args.seed)
        return
    print(f"uptime: {os.getloadavg()} (1, 5, 15 min load averages)")
    if SMOKE:
        args.repeats, args.slow_repeats = min(args.repeats, 2), 1
        print("TORCHSHM_SMOKE=1: size B only, 2 repeats, a check that the script runs, not a benchmark")
        print(bench_size("B", 1, args))
        return
    if args.only_scaling:
        scaling(args)
        return
    if args.only_draws:
        draws(args)
        print(f"\nuptime after: {os.getloadavg()}")
        return
    if args.only_celerite:
        against_celerite(args)
        print(f"\nuptime after: {os.getloadavg()}")
        return
    if args.only_dense:
        dense_fibre(args)
        return
    rows = bench_size("C1", 11, args) + bench_size("B", 1, args)
    print(
        f"torch {torch.__version__} ({torch.get_num_threads()} threads), numpy {np.__version__}, "
        f"{platform.machine()}; median of {args.repeats} calls ({args.slow_repeats} for (a) and "
        f"(b), {max(3, args.repeats // 4)} for (d)) after one warm-up; times per parameter vector."
        "\n"
    )
    print("| size | method | wall [ms] | CPU [ms] | (a) ÷ this, wall | (a) ÷ this, CPU |")
    print("| --- | --- | ---: | ---: | ---: | ---: |")
    naive: dict[str, Row] = {}
    for row in rows:
        ref = naive.setdefault(row.size, row)
        print(
            f"| {row.size} | {row.method} | {1e3 * row.wall:.4g} | {1e3 * row.cpu:.4g} "
            f"| {ref.wall / row.wall:.4g}x | {ref.cpu / row.cpu:.4g}x |"
        )
    for size, ref in naive.items():
        spread = max(abs(r.value - ref.value) / abs(ref.value) for r in rows if r.size == size)
        print(f"\n{size}: largest relative difference from (a)'s value: {spread:.1e}")


    dense_fibre(args)


def dense_fibre(args: argparse.Namespace) -> None:
    """The O(n) part: crossover, 10^5 x 12 beside celerite2, draws, scaling to 10^6."""
    crossover(args)
    against_celerite(args)
    draws(args)
    scaling(args)
    print(f"\nuptime after: {os.getloadavg()}")


if __name__ == "__main__":
    main()

"""Benchmark of the full-scale and Vecchia forms of Eq. (21) on 2-D fields (``docs/likelihood.md``).

Three parts, run by ``scripts/bench_likelihood.py --only-field`` (error and scaling), or this
file directly:

- error: Δ log-likelihood of plain Vecchia (m = 10) and of the full-scale form of
  ``method="auto"`` (rank and neighbours chosen per call) against the exact dense value, over the priors'
  range (σa 0.2 and 5 µε, l = 0.02, 0.2 and 1 × the field size, σe 0.05 and 1 µε, σm 0 and
  0.05; ``--corners``: σa = 5, σe = 0.05 only), on a `side x side` grid of a unit square, with
  y drawn from the exact Gaussian and a heteroscedastic diagonal (η uniform in 20..100 µε);
- time and memory: one parameter vector, one load case, Matérn 3/2, σa = 1 µε, l = 0.05 m,
  σe = 0.1 µε, σm = 0.05, at 10^4, 10^5 and 10^6 grid points, each size and form in a fresh
  process (peak resident set during the calls minus before them): the plan (order and
  neighbours, once per point set), one call, for the Vecchia form one predictive draw, and
  beside the full-scale form at 10^4 the dense path, scikit-learn's exact
  ``GaussianProcessRegressor.log_marginal_likelihood`` (the same kernel and diagonal) and a
  plain numpy computation of the Vecchia sum (m = 10) on the same conditioning sets;
- posterior (``--posterior-only``): a grid posterior of (σa, l), dense against both forms;
- ``--adaptive-side S``: one call of ``"auto"`` per kernel, length and σm at the error table's
  corners at S² points (the rank and neighbours it chose, CPU and wall time, memory).

Usage (from the repository root)::

    PYTHONPATH=. OMP_NUM_THREADS=1 python scripts/bench_likelihood_field.py [--side 50] [--corners]
        [--kernels a,b] [--sides 100,316,1000] [--error-only | --scaling-only | --posterior-only]
"""

from __future__ import annotations

import argparse
import itertools
import math
import os
import subprocess
import sys
import time

import numpy as np
import torch
from bench_likelihood_keops import _peak_rss_bytes, _rss_bytes  # a sibling script (scripts/ is on the path)

import torchshm
from torchshm.kernels import get_kernel
from torchshm.likelihood import fullscale, fullscale_choice, marginal, neighbours, vecchia

KERNELS = ("exponential", "matern32", "matern52", "squared_exponential")
SA, LENGTH, SE, SM = 1.0, 0.05, 0.1, 0.05


def grid(side: int) -> np.ndarray:
    """`side² x 2` points of a regular grid on the unit square [m]."""
    g = np.linspace(0.0, 1.0, side)
    return np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)


def error(side: int, seed: int, corners: bool = False, kernels: tuple[str, ...] = KERNELS) -> None:
    """The error table over the priors' range (one dense factorisation per row): plain Vecchia
    (m = 10) and the full-scale form that ``method="auto"`` takes (rank and neighbours chosen
    per call, shown); ``corners``: only σa = 5 µε, σe = 0.05 µε (largest signal, smallest
    noise), σm 0 and 0.05."""
    x = torch.as_tensor(grid(side))
    n = x.shape[0]
    rng = np.random.default_rng(seed)
    eta = torch.as_tensor(rng.uniform(20.0, 100.0, (1, n)))
    print(f"\n{n:,} points ({side} x {side} grid of the unit square): approximation − dense [nat]\n")
    print("| kernel | σa [µε] | l | σe [µε] | σm | vecchia m = 10 | fullscale (auto) | rank, m | CPU [s] fullscale / dense |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for name in kernels:
        kern = get_kernel(name)
        grid_ = itertools.product((0.2, 5.0), (0.02, 0.2, 1.0), (0.05, 1.0), (0.0, 0.05))
        if corners:
            grid_ = [(5.0, ell, 0.05, sm) for ell in (0.02, 0.2, 1.0) for sm in (0.0, 0.05)]
        for sa, ell, se, sm in grid_:
            noise = sm**2 * eta[None] ** 2 + se**2
            start = time.process_time()
            cov = marginal.covariance(x, kern, torch.tensor([sa]), torch.tensor([ell]), noise)[0, 0]
            chol = torch.linalg.cholesky(cov)
            z = torch.as_tensor(rng.standard_normal(n))
            y = eta + (chol @ z)[None]
            # the exact dense log density from the same factor (what method="dense" computes)
            exact = -0.5 * (z.square().sum() + 2.0 * chol.diagonal().log().sum() + n * math.log(2.0 * math.pi))
            dense_cpu = time.process_time() - start
            del cov, chol
            plain = float(torchshm.log_likelihood(y, eta, x, name, sa, ell, sm, se, method="vecchia") - exact)
            start = time.process_time()
            full = float(torchshm.log_likelihood(y, eta, x, name, sa, ell, sm, se, method="fullscale") - exact)
            cpu = time.process_time() - start
            used = _setting(x, kern, sa, ell, noise)
            print(f"| {name} | {sa} | {ell} | {se} | {sm} | {plain:+.3f} | {full:+.3f} | {used} | {cpu:.2f} / {dense_cpu:.1f} |", flush=True)


def _setting(x: torch.Tensor, kern: object, sa: float, ell: float, noise: torch.Tensor) -> str:
    plan, pivots, _ = fullscale.setting(x, kern, torch.tensor([sa]), torch.tensor([ell]), noise)  # type: ignore[arg-type]
    return f"{pivots.numel()}, {plan.neighbours}"  # rank, m of the full-scale form's choice


def adaptive_timing(side: int, seed: int, kernels: tuple[str, ...] = KERNELS) -> None:
    """(child process) one call of ``method="auto"`` per kernel, length (0.02, 0.2, 1 × the
    field) and σm (0, 0.05), σa = 5 µε, σe = 0.05 µε (the error table's corners), at `side²`
    points: the plans first (once per point set and m), then one call per row; peak memory growth
    of the whole process."""
    torch.set_num_threads(1)
    xy = grid(side)
    n = xy.shape[0]
    rng = np.random.default_rng(seed)
    eta = torch.as_tensor(rng.uniform(20.0, 100.0, (1, n)))
    y = eta + torch.as_tensor(rng.normal(0.0, 1.0, (1, n)))
    x = torch.as_tensor(xy)
    small = torch.as_tensor(grid(20))  # warm-up: first-call initialisation is not part of the growth
    torchshm.log_likelihood(eta[:, :400] + 1.0, eta[:, :400], small, "matern32", 1.0, 0.1, 0.05, 0.05, method="fullscale")
    before = _rss_bytes()
    for m in sorted({fullscale.neighbours_for(n, v) for v in (fullscale_choice.NEIGHBOURS_RESOLVED, fullscale_choice.NEIGHBOURS_MAX)}):
        start_cpu, start = time.process_time(), time.perf_counter()
        neighbours.plan(xy, m)
        print(f"{n:,}\tplan, m = {m} (once per point set)\t\t\t{time.perf_counter() - start:.2f}\t{time.process_time() - start_cpu:.2f}\t", flush=True)
    for name in kernels:
        for ell, sm in itertools.product((0.02, 0.2, 1.0), (0.0, 0.05)):
            start_cpu, start = time.process_time(), time.perf_counter()
            with torch.no_grad():
                value = float(torchshm.log_likelihood(y, eta, x, name, 5.0, ell, sm, 0.05, method="fullscale"))
            wall, cpu = time.perf_counter() - start, time.process_time() - start_cpu
            used = _setting(x, get_kernel(name), 5.0, ell, sm**2 * eta[None] ** 2 + 0.05**2)
            print(f"{n:,}\t{name}\t{ell}\t{sm}\t{used}\t{wall:.3f}\t{cpu:.3f}\t{value:.1f}", flush=True)
    print(f"{n:,}\tpeak memory growth [MB]\t\t\t\t\t{(_peak_rss_bytes() - before) / 2**20:.0f}\t")


def posterior_grid(seed: int, side: int, kernels: tuple[str, ...], steps: int = 9) -> None:
    """Grid posterior of (log σa, log l) under a flat prior, dense against the full-scale form
    (``"auto"``) and plain Vecchia (m = 10): `side²` points, y drawn at σa = 1 µε, l = 0.1
    (about 7 pitches at side 70), σe = 0.1 µε, σm = 0.05; `steps x steps` grid, σa 0.8..1.25 µε,
    l 0.07..0.14 (log-spaced; about ±2 sd around the truth)."""
    n = side * side
    x = torch.as_tensor(grid(side))
    rng = np.random.default_rng(seed)
    sa = np.exp(np.linspace(np.log(0.8), np.log(1.25), steps))
    ell = np.exp(np.linspace(np.log(0.07), np.log(0.14), steps))
    s_grid, l_grid = (torch.as_tensor(a.ravel()) for a in np.meshgrid(sa, ell, indexing="ij"))
    print(f"\n{n:,} points; | kernel | method | mean ± sd of log σa | mean ± sd of log l | CPU [s] |\n| --- | --- | ---: | ---: | ---: |")
    for name in kernels:
        eta = torch.as_tensor(rng.uniform(20.0, 100.0, (1, n)))
        cov = marginal.covariance(x, get_kernel(name), torch.tensor([1.0]), torch.tensor([0.1]), SM**2 * eta[None] ** 2 + SE**2)
        y = eta + (torch.linalg.cholesky(cov[0, 0]) @ torch.as_tensor(rng.standard_normal(n)))[None]
        del cov
        for method in ("dense", "fullscale", "vecchia"):
            start = time.process_time()
            with torch.no_grad():
                v = torch.stack([torchshm.log_likelihood(y, eta, x, name, a, b, SM, SE, method=method) for a, b in zip(s_grid, l_grid)])
            w = torch.softmax(v, 0)
            cells = []
            for t in (s_grid.log(), l_grid.log()):
                mean = float((w * t).sum())
                cells.append(f"{mean:.4f} ± {float((w * (t - mean).square()).sum()) ** 0.5:.4f}")
            print(f"| {name} | {method} | {cells[0]} | {cells[1]} | {time.process_time() - start:.0f} |", flush=True)


def numpy_vecchia(y: np.ndarray, eta: np.ndarray, xy: np.ndarray, plan: neighbours.Plan) -> float:
    """The Vecchia sum of Matérn 3/2 on the plan's conditioning sets, in plain numpy."""
    total = 0.0
    xo, r = xy[plan.order], (y - eta)[plan.order]
    d = SM**2 * eta[plan.order] ** 2 + SE**2
    for start in range(0, xo.shape[0], 2**14):
        rows = plan.blocks[start : start + 2**14]
        valid = rows >= 0
        safe = np.where(valid, rows, rows[:, -1:])
        dist = np.linalg.norm(xo[safe][:, :, None] - xo[safe][:, None], axis=-1)
        s = np.sqrt(3.0) * dist / LENGTH
        cov = np.where(valid[:, :, None] & valid[:, None], SA**2 * (1 + s) * np.exp(-s), 0.0)
        cov[:, np.arange(rows.shape[1]), np.arange(rows.shape[1])] = np.where(valid, SA**2 + d[safe], 1.0)
        chol = np.linalg.cholesky(cov)
        z = np.linalg.solve(chol, np.where(valid, r[safe], 0.0)[..., None])[:, -1, 0]
        total -= 0.5 * (z**2 + 2 * np.log(chol[:, -1, -1]) + np.log(2 * np.pi)).sum()
    return total


def one_size(side: int, seed: int, method: str) -> None:
    """(child process) plan, one call of ``method``, peak memory growth; for the Vecchia form a
    predictive draw, for the full-scale form at 10^4 the references as well."""
    torch.set_num_threads(1)
    xy = grid(side)
    n = xy.shape[0]
    rng = np.random.default_rng(seed)
    eta = rng.uniform(20.0, 100.0, n)
    y = eta + rng.normal(0.0, 1.0, n)
    x, yt, et = torch.as_tensor(xy), torch.as_tensor(y[None]), torch.as_tensor(eta[None])
    small = torch.as_tensor(grid(20))  # warm-up: first-call initialisation is not part of the growth
    torchshm.log_likelihood(yt[:, :400], et[:, :400], small, "matern32", SA, LENGTH, SM, SE, method=method)
    m = vecchia.neighbour_count(get_kernel("matern32"))
    what = f"m = {m}"
    if method == "fullscale":
        m = fullscale.neighbours_for(n, fullscale_choice.NEIGHBOURS_MAX)
        what = f"m and rank chosen per call, at most m = {m}, rank {fullscale.rank_for(n, marginal.FULLSCALE_RANK)}"
    before = _rss_bytes()
    start_cpu, start = time.process_time(), time.perf_counter()
    plan = neighbours.plan(xy, m)
    rows = [(f"plan, {what} (order, neighbours, distances; once per point set)", time.perf_counter() - start, time.process_time() - start_cpu, "")]
    for _ in range(2):
        start_cpu, start = time.process_time(), time.perf_counter()
        with torch.no_grad():
            value = float(torchshm.log_likelihood(yt, et, x, "matern32", SA, LENGTH, SM, SE, method=method))
        rows.append((f"`torchshm.log_likelihood`, method={method!r} ({what})", time.perf_counter() - start, time.process_time() - start_cpu, f"{value:.3f}"))
    del rows[1]  # the first call after the plan
    if method == "vecchia":
        gaussian = marginal.Eq21(et[None], x, get_kernel("matern32"), torch.tensor([SA]), torch.tensor([LENGTH]), SM, SE, "vecchia")
        start_cpu, start = time.process_time(), time.perf_counter()
        draw = gaussian.sample(torch.Generator().manual_seed(seed))
        rows.append((f"one predictive draw, `Eq21.sample` (Vecchia, {what})", time.perf_counter() - start, time.process_time() - start_cpu, f"sd {float((draw - et).std()):.3f}"))
    peak = _peak_rss_bytes()
    if n <= 10_000 and method == "fullscale":
        rows += _references(xy, y, eta, x, yt, et, neighbours.plan(xy, 10))
    for label, wall, cpu, val in rows:
        print(f"{label}\t{wall}\t{cpu}\t{val}")
    print(f"growth\t{max(0, peak - before)}")


def _references(xy, y, eta, x, yt, et, plan) -> list[tuple[str, float, float, str]]:  # noqa: ANN001
    """Dense torch, scikit-learn's exact GP and the numpy Vecchia sum at the same size."""
    from sklearn.gaussian_process import GaussianProcessRegressor
    from sklearn.gaussian_process.kernels import ConstantKernel, Matern

    out = []
    jobs = [
        ("`torchshm.log_likelihood`, method='dense' (exact)",
         lambda: float(torchshm.log_likelihood(yt, et, x, "matern32", SA, LENGTH, SM, SE, method="dense"))),
        ("scikit-learn `GaussianProcessRegressor`, exact (alpha = diagonal)", lambda: _sklearn(xy, y, eta, GaussianProcessRegressor, ConstantKernel, Matern)),
        ("plain numpy Vecchia sum, same conditioning sets", lambda: numpy_vecchia(y, eta, xy, plan)),
    ]
    for label, fn in jobs:
        start_cpu, start = time.process_time(), time.perf_counter()
        with torch.no_grad():
            value = fn()
        out.append((label, time.perf_counter() - start, time.process_time() - start_cpu, f"{value:.3f}"))
    return out


def _sklearn(xy, y, eta, gpr, constant, matern) -> float:  # noqa: ANN001
    kernel = constant(SA**2, constant_value_bounds="fixed") * matern(LENGTH, length_scale_bounds="fixed", nu=1.5)
    model = gpr(kernel, alpha=SM**2 * eta**2 + SE**2, optimizer=None, normalize_y=False).fit(xy, y - eta)
    return float(model.log_marginal_likelihood_value_)


def scaling(seed: int, sides: tuple[int, ...] = (100, 316, 1000)) -> None:
    """10^4, 10^5, 10^6 points, one fresh process per size and method."""
    print("\n| n | what | wall [s] | CPU [s] | value | peak memory growth [MB] |")
    print("| ---: | --- | ---: | ---: | ---: | ---: |")
    for side in sides:
        for method in ("vecchia", "fullscale"):
            out = subprocess.run(
                [sys.executable, __file__, "--one-side", str(side), "--method", method, "--seed", str(seed)],
                check=True, capture_output=True, text=True, env={**os.environ, "OMP_NUM_THREADS": "1"},
            ).stdout.strip().splitlines()
            grow = int(out[-1].split("\t")[1]) / 2**20
            for line in out[:-1]:
                label, wall, cpu, val = line.split("\t")
                mem = f"{grow:.0f}" if label.startswith("`torchshm.log_likelihood`, method=") and "dense" not in label else ""
                print(f"| {side * side:,} | {label} | {float(wall):.3f} | {float(cpu):.3f} | {val} | {mem} |", flush=True)




def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--side", type=int, default=50, help="grid side of the error table")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--corners", action="store_true", help="error table: largest σa, smallest σe only")
    parser.add_argument("--kernels", default=",".join(KERNELS), help="comma-separated kernels of the error/posterior tables")
    parser.add_argument("--steps", type=int, default=9, help="grid posterior: steps per parameter")
    parser.add_argument("--posterior-only", action="store_true", help="grid posterior of (σa, l), dense vs Vecchia")
    parser.add_argument("--error-only", action="store_true")
    parser.add_argument("--scaling-only", action="store_true")
    parser.add_argument("--adaptive-side", type=int, default=0, help="only the adaptive timing table at side² points")
    parser.add_argument("--one-side", type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument("--method", default="vecchia", help=argparse.SUPPRESS)
    parser.add_argument("--sides", default="100,316,1000", help="grid sides of the scaling table")
    args = parser.parse_args(argv)
    torch.set_num_threads(1)
    if args.one_side:
        one_size(args.one_side, args.seed, args.method)
        return
    if args.adaptive_side:
        print(f"uptime: {os.getloadavg()}; n, kernel, l, σm, (rank, m), wall [s], CPU [s], value")
        adaptive_timing(args.adaptive_side, args.seed, tuple(args.kernels.split(",")))
        print(f"uptime after: {os.getloadavg()}")
        return
    print(f"uptime: {os.getloadavg()} (1, 5, 15 min load averages); torch {torch.__version__}, 1 thread")
    kernels = tuple(args.kernels.split(","))
    if args.posterior_only:
        posterior_grid(args.seed, args.side, kernels, args.steps)
        return
    if not args.scaling_only:
        error(args.side, args.seed, args.corners, kernels)
    if not args.error_only:
        scaling(args.seed, tuple(int(v) for v in args.sides.split(",")))
    print(f"\nuptime after: {os.getloadavg()}")


if __name__ == "__main__":
    main()

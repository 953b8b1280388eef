"""The 2-D field likelihood beside an external implementation of the same kernel: GPyTorch.

One parameter vector, one load case, Matérn 3/2 (σa = 1 µε, l = 0.05 m, σe = 0.1 µε,
σm = 0.05, η uniform in 20..100 µε; the residual y − η drawn as white noise of 1 µε, as in
``bench_likelihood_field.py``'s scaling table) on a `side x side` grid of the unit square.
Rows, each in a fresh process (peak resident set during the call minus before it):

- ``torchshm.log_likelihood``, ``method="auto"`` (the full-scale form from 5,000 points; its
  rank and neighbours chosen per call) and, where it fits, ``method="dense"`` (exact);
- GPyTorch's exact path: ``ExactMarginalLogLikelihood`` of an ``ExactGP`` with
  ``ScaleKernel(MaternKernel(nu=1.5))`` and ``FixedNoiseGaussianLikelihood`` (the
  heteroscedastic diagonal), Cholesky (``max_cholesky_size`` above n);
- GPyTorch's BBMM with KeOps: the same model with ``gpytorch.kernels.keops.MaternKernel``
  (exact kernel matrix-vector products compiled by pykeops, never an `n x n` matrix),
  ``max_cholesky_size(0)``: conjugate gradients and stochastic Lanczos quadrature with
  GPyTorch's defaults (10 probe vectors, training CG tolerance 1) but no preconditioner
  (GPyTorch's pivoted-Cholesky preconditioner fails on KeOps kernels here, see
  ``gpytorch_value``), then with a CG tolerance of 0.01 and 50 probes. Its value is random
  (the probes; seeded here).

pykeops compiles C++ with the system's g++ on first use (tens of seconds, cached in
``~/.cache/keops*``); with ``TORCHSHM_SMOKE=1`` or without pykeops its rows are skipped with
the reason. Usage::

    OMP_NUM_THREADS=1 python scripts/bench_likelihood_keops.py [--sides 32,100,316] [--seed 0]
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import subprocess
import sys
import time

import numpy as np
import torch

import torchshm

SA, LENGTH, SE, SM = 1.0, 0.05, 0.1, 0.05
SMOKE = os.environ.get("TORCHSHM_SMOKE") == "1"
#: rows per size: (label, largest n it runs at)
ROWS = (
    ("`torchshm.log_likelihood`, method='dense' (exact)", 10_000),
    ("`torchshm.log_likelihood`, method='auto'", 10**7),
    ("GPyTorch exact (Cholesky), `MaternKernel`", 10_000),
    ("GPyTorch BBMM + KeOps `MaternKernel`, defaults", 100_000),
    ("GPyTorch BBMM + KeOps `MaternKernel`, CG tol 0.01, 50 probes", 10_000),
)


def data(side: int, seed: int) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """`n x 2` grid [m], measurements `1 x n` and model responses `1 x n` [µε]."""
    g = np.linspace(0.0, 1.0, side)
    xy = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)
    rng = np.random.default_rng(seed)
    eta = rng.uniform(20.0, 100.0, xy.shape[0])
    y = eta + rng.normal(0.0, 1.0, xy.shape[0])
    return torch.as_tensor(xy), torch.as_tensor(y[None]), torch.as_tensor(eta[None])


def keops_missing() -> str:
    """Why the KeOps rows cannot run here ('' when they can)."""
    if SMOKE:
        return "TORCHSHM_SMOKE=1: pykeops compiles C++ on first use (tens of seconds); not in the smoke"
    if importlib.util.find_spec("pykeops") is None:
        return "pykeops is not installed (`pip install torchshm[bench]`)"
    return ""


def gpytorch_value(x: torch.Tensor, y: torch.Tensor, eta: torch.Tensor, row: int) -> float:
    """GPyTorch's log marginal likelihood [nat] of ``y - eta`` (row 2: Cholesky, 3 and 4: BBMM + KeOps)."""
    import gpytorch

    if row == 2:
        base = gpytorch.kernels.MaternKernel(nu=1.5)
    else:
        from gpytorch.kernels.keops import MaternKernel

        base = MaternKernel(nu=1.5)
    kernel = gpytorch.kernels.ScaleKernel(base).double()
    base.lengthscale = LENGTH
    kernel.outputscale = SA**2
    resid = (y - eta)[0]
    noise = (SM**2 * eta[0].square() + SE**2)
    likelihood = gpytorch.likelihoods.FixedNoiseGaussianLikelihood(noise=noise).double()

    class Model(gpytorch.models.ExactGP):
        def forward(self, z: torch.Tensor) -> gpytorch.distributions.MultivariateNormal:
            return gpytorch.distributions.MultivariateNormal(torch.zeros_like(z[:, 0]), kernel(z))

    model = Model(x, resid, likelihood).double()
    mll = gpytorch.mlls.ExactMarginalLogLikelihood(likelihood, model)
    n = x.shape[0]
    cholesky = gpytorch.settings.max_cholesky_size(n + 1 if row == 2 else 0)
    tight = row == 4
    # no preconditioner with KeOps: linear_operator's pivoted Cholesky asks the KeOps kernel for
    # its diagonal as a dense tensor and fails (gpytorch 1.15.2, linear_operator 0.6.1, pykeops 2.3)
    precond = gpytorch.settings.max_preconditioner_size(15 if row == 2 else 0)
    with torch.no_grad(), cholesky, precond, gpytorch.settings.cg_tolerance(0.01 if tight else 1.0), \
            gpytorch.settings.num_trace_samples(50 if tight else 10):
        return float(mll(model(x), resid)) * n


def one_row(side: int, row: int, seed: int) -> None:
    """(child process) wall, CPU, value and peak memory growth of one row."""
    torch.set_num_threads(1)
    torch.manual_seed(seed)
    x, y, eta = data(side, seed)
    if row == 1:  # the plan (once per point set) is not part of the call
        torchshm.log_likelihood(y, eta, x, "matern32", SA, LENGTH, SM, SE)
    if row <= 2:  # first-call initialisation is not part of the call
        xs, ys, es = data(12, seed)
        torchshm.log_likelihood(ys, es, xs, "matern32", SA, LENGTH, SM, SE, method="dense")
        if row == 2:
            gpytorch_value(xs, ys, es, row)
    if row >= 3:  # KeOps compiles on first use: a warm-up call on a small grid
        xs, ys, es = data(20, seed)
        gpytorch_value(xs, ys, es, row)
    before = _rss_bytes()
    start, start_cpu = time.perf_counter(), time.process_time()
    with torch.no_grad():
        if row <= 1:
            method = "dense" if row == 0 else "auto"
            value = float(torchshm.log_likelihood(y, eta, x, "matern32", SA, LENGTH, SM, SE, method=method))
        else:
            value = gpytorch_value(x, y, eta, row)
    wall, cpu = time.perf_counter() - start, time.process_time() - start_cpu
    print(f"{wall}\t{cpu}\t{value}\t{max(0, _peak_rss_bytes() - before)}")


def table(sides: tuple[int, ...], seed: int, timeout: float) -> None:
    """The markdown table: every row at every size it runs at, each in a fresh process."""
    missing = keops_missing()
    print("| n | what | wall [s] | CPU [s] | log-likelihood [nat] | − dense [nat] | peak memory growth [MB] |")
    print("| ---: | --- | ---: | ---: | ---: | ---: | ---: |")
    for side in sides:
        n, exact = side * side, None
        for row, (label, largest) in enumerate(ROWS):
            if n > largest:
                continue
            if row >= 3 and missing:
                print(f"| {n:,} | {label} | skipped: {missing} | | | | |", flush=True)
                continue
            try:
                out = subprocess.run(
                    [sys.executable, __file__, "--one", str(side), str(row), "--seed", str(seed)], check=True,
                    capture_output=True, text=True, timeout=timeout, env={**os.environ, "OMP_NUM_THREADS": "1"},
                ).stdout.strip().splitlines()[-1].split("\t")
            except subprocess.TimeoutExpired:
                print(f"| {n:,} | {label} | stopped after {timeout:.0f} s | | | | |", flush=True)
                continue
            except subprocess.CalledProcessError as err:
                print(f"| {n:,} | {label} | failed: {err.stderr.strip().splitlines()[-1][:120]} | | | | |", flush=True)
                continue
            wall, cpu, value, grow = float(out[0]), float(out[1]), float(out[2]), int(out[3])
            exact = value if row == 0 else exact
            diff = f"{value - exact:+.3f}" if exact is not None and row != 0 else ""
            print(f"| {n:,} | {label} | {wall:.3f} | {cpu:.3f} | {value:.3f} | {diff} | {grow / 2**20:.0f} |", flush=True)


def _rss_bytes() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def _peak_rss_bytes() -> int:
    with open("/proc/self/status") as f:
        return int(next(r for r in f if r.startswith("VmHWM:")).split()[1]) * 1024


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sides", default="32,100,316", help="grid sides (n = side²)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--timeout", type=float, default=600.0, help="seconds per row before it is stopped")
    parser.add_argument("--one", type=int, nargs=2, default=None, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.one:
        one_row(args.one[0], args.one[1], args.seed)
        return
    sides = (12,) if SMOKE else tuple(int(v) for v in args.sides.split(","))
    print(f"uptime: {os.getloadavg()} (1, 5, 15 min load averages); torch {torch.__version__}, 1 thread")
    table(sides, args.seed, args.timeout)
    print(f"\nuptime after: {os.getloadavg()}")


if __name__ == "__main__":
    main()

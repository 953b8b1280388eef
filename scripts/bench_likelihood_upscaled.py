"""Benchmark of the upscaled-field form of Eq. (21) (kernel ``upscaled``): the multifrontal
elimination in torch beside SciPy's sparse LU, the form it replaced, in the same process.

A field written three times finer than its element grid (muDIC's ``Fields(upscale=3)``), 1 % of
the points lost at random, two load cases with the same diagonal (σm = 0, σe = 20 µε, σa =
680 µε: the camera example's levels), residuals one exact draw of the Gaussian. Each size runs
in a fresh process, one thread (``OMP_NUM_THREADS=1``): CPU time (``time.process_time``) of

- ``upscaled.log_density`` (torch): a first call (it cuts the element grid into fronts, cached
  per grid shape), a next call, and a call with the gradients in the residuals and σa;
- ``upscaled._sparse_lu`` (SuperLU of ``I + σa² Uᵀ D⁻¹ U`` over the elements seen: the form
  before) and the two values' difference;
- at the smallest size, the dense Gaussian (Cholesky of ``σa² U Uᵀ + σe² I``) and the difference;
- draws of the element noise, torch (``upscaled.sample``: a first one, which builds ``U``, then
  the next 20, ``U`` kept from draw to draw as the chunked predictive keeps it) against SciPy's
  sparse product ``σa U z`` of the form before (20 draws);

and the peak memory growth of the torch and sparse LU calls (``VmHWM`` after them minus the
resident set before them; the draws and the dense check come after it).
``--grids`` picks the element grids (default 40x30, 155x113, 400x300: 1e4, 1.6e5, 1.1e6 points).
``TORCHSHM_SMOKE=1``: one grid of 12x10 elements (about 1,000 points), a check that it runs.

Usage (from the repository root)::

    OMP_NUM_THREADS=1 .venv/bin/python scripts/bench_likelihood_upscaled.py [--grids 40x30,155x113]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time

import numpy as np
import torch

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

from torchshm.kernels.upscaled import operator  # noqa: E402
from torchshm.likelihood import upscaled  # noqa: E402

ELEMENT, SA, SE, LOADS = 0.012, 680.0, 20.0, 2


def field(nx: int, ny: int, seed: int) -> np.ndarray:
    """`n x 2` points [m] written 3 times finer than an `nx x ny` element grid, 1 % lost."""
    step = ELEMENT / 3
    gx, gy = np.meshgrid(step * np.arange(3 * (nx - 1) + 1), step * np.arange(3 * (ny - 1) + 1), indexing="ij")
    x = np.column_stack([gx.ravel(), gy.ravel()])
    keep = np.random.default_rng(seed).random(len(x)) > 0.01
    keep[[0, -1]] = True
    return x[keep]


def _rss(name: str) -> int:
    with open("/proc/self/status") as f:
        return int(next(row for row in f if row.startswith(name)).split()[1]) * 1024


def _cpu(call):
    start = time.process_time()
    out = call()
    return out, time.process_time() - start


def child(nx: int, ny: int, seed: int) -> None:
    """One grid: tab-separated ``label, value`` rows."""
    torch.set_num_threads(1)
    x = field(nx, ny, seed)
    n = x.shape[0]
    u = operator(x, ELEMENT)
    rng = np.random.default_rng(seed + 1)
    resid = SA * (u @ rng.standard_normal((u.shape[1], LOADS))).T + SE * rng.standard_normal((LOADS, n))
    r, d = torch.tensor(resid[None]), torch.full((1, LOADS, n), SE**2, dtype=torch.float64)
    xt, sa, ell = (torch.tensor(v, dtype=torch.float64) for v in (x, [SA], [ELEMENT]))
    before = _rss("VmRSS:")
    print(f"points\t{n}\nelements\t{nx * ny}")
    value, cpu = _cpu(lambda: float(upscaled.log_density(r, d, xt, sa, ell)[0]))
    print(f"torch first\t{cpu}")
    _, cpu = _cpu(lambda: upscaled.log_density(r, d, xt, sa, ell))
    print(f"torch next\t{cpu}")

    def with_gradient() -> None:
        rg, sg = r.clone().requires_grad_(True), sa.clone().requires_grad_(True)
        upscaled.log_density(rg, d, xt, sg, ell).sum().backward()

    _, cpu = _cpu(with_gradient)
    print(f"torch with gradients\t{cpu}")
    lu, cpu = _cpu(lambda: upscaled._sparse_lu(r[0], d[0], operator(x, ELEMENT), SA))  # U built, as each call did
    print(f"sparse LU\t{cpu}\ntorch - sparse LU [nat]\t{value - lu}\nvalue\t{value}")
    print(f"peak memory growth [MB]\t{(_rss('VmHWM:') - before) / 2**20}")
    gen, ops = torch.Generator().manual_seed(seed), {}
    _, cpu = _cpu(lambda: upscaled.sample(xt, sa, ell, LOADS, gen, ops))
    print(f"first draw torch (with U)\t{cpu}")

    def torch_draws() -> None:
        for _ in range(20):
            upscaled.sample(xt, sa, ell, LOADS, gen, ops)

    def sparse_draws() -> None:
        for _ in range(20):
            z = torch.randn(LOADS, u.shape[1], generator=gen, dtype=torch.float64).numpy()
            SA * (u @ z.T).T

    _, cpu = _cpu(torch_draws)
    print(f"next draw torch\t{cpu / 20}")
    _, cpu = _cpu(sparse_draws)
    print(f"next draw SciPy sparse product\t{cpu / 20}")
    if n <= 12_000:
        dense = SA**2 * (u @ u.T).toarray() + SE**2 * np.eye(n)
        chol = np.linalg.cholesky(dense)
        z = np.linalg.solve(chol, resid.T)
        exact = -0.5 * ((z**2).sum() + LOADS * (2 * np.log(np.diag(chol)).sum() + n * np.log(2 * np.pi)))
        print(f"torch - dense [nat]\t{value - exact}\nsparse LU - dense [nat]\t{lu - exact}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grids", default="40x30,155x113,400x300")
    parser.add_argument("--child", help=argparse.SUPPRESS)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    if args.child:
        child(*map(int, args.child.split("x")), args.seed)
        return
    grids = ["12x10"] if os.environ.get("TORCHSHM_SMOKE") == "1" else args.grids.split(",")
    print(f"started {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, load average "
          + ", ".join(f"{v:.1f}" for v in os.getloadavg()) + f", torch {torch.__version__}, one thread")
    env = {**os.environ, "OMP_NUM_THREADS": "1", "KEOPS_VERBOSE": "0"}
    rows = []
    for grid in grids:
        out = subprocess.run([sys.executable, __file__, "--child", grid, "--seed", str(args.seed)],
                             capture_output=True, text=True, env=env, check=True).stdout
        rows.append(dict(line.split("\t") for line in out.strip().splitlines()))
    keys = list(rows[0])
    print("| " + " | ".join(["quantity"] + [f"{int(r['points']):,} points" for r in rows]) + " |")
    print("| --- |" + " ---: |" * len(rows))
    for key in keys[2:]:
        cells = [f"{float(r[key]):.3g}" if key in r else "–" for r in rows]
        print(f"| {key} | " + " | ".join(cells) + " |")
    print("load average at the end " + ", ".join(f"{v:.1f}" for v in os.getloadavg()))


if __name__ == "__main__":
    main()

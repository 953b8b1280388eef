"""The squared exponential along a line: the reduced-rank form against the dense Cholesky.

Two parts, in one process (``docs/likelihood.md``, "The squared exponential along a line"):

1. **Error.** For `n` positions over 12 m, lengths from 1/100 of the line to twice it, scales
   σa of 1 and 3 µε, noise σe of 0.1 and 0.001 µε and σm of 0 and 0.05: data drawn from
   Eq. (21) at that length, the log-likelihood of three load cases by ``method="auto"`` (the
   reduced-rank form where its basis is at most ``hilbert.SHARE`` of the points, else dense)
   and by ``method="dense"``. Printed: the basis size, the form taken, the worst difference.
2. **Time.** `B` = 48 parameter vectors (a round of the emulator's chains), `L` = 4 load cases,
   σm = 0.05: the CPU seconds of value and gradient in the strains, σa and l, dense against
   auto, alternating, the median of three.

``TORCHSHM_SMOKE=1``: one size of 200 points, one repeat (a check that it runs).

    OMP_NUM_THREADS=1 python scripts/bench_likelihood_hilbert.py
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import torch

from torchshm.kernels import get_kernel
from torchshm.likelihood import hilbert, log_likelihood

SMOKE = os.environ.get("TORCHSHM_SMOKE") == "1"
KERNEL = get_kernel("squared_exponential")
SPAN = 12.0  # m


def draw(n: int, loads: int, batch: int, length: float, sigma_a: float, sigma_e: float, sigma_m: float,
         seed: int) -> tuple[torch.Tensor, ...]:
    """Positions, `batch x loads x n` responses and data drawn from Eq. (21) for the first."""
    gen = torch.Generator().manual_seed(seed)
    x = torch.linspace(0.0, SPAN, n, dtype=torch.float64)
    eta = 50.0 * torch.sin(x / 2.5) + torch.randn(batch, loads, n, generator=gen, dtype=torch.float64)
    cov = KERNEL(x, sigma_a=sigma_a, length=length) + torch.diag_embed(sigma_e**2 + sigma_m**2 * eta[0].square())
    y = eta[0] + (torch.linalg.cholesky(cov) @ torch.randn(loads, n, 1, generator=gen, dtype=torch.float64))[..., 0]
    return x, eta, y


def errors(n: int) -> None:
    print(f"\n### Error at {n} points over {SPAN:g} m (3 load cases)\n")
    print("| length [m] | basis m | form | worst \\|Δ log-likelihood\\| [nat] over σa, σe, σm |")
    print("| ---: | ---: | --- | ---: |")
    for length in (0.12, 0.3, 0.6, 1.2, 3.0, 8.0, 24.0):
        worst = 0.0
        for seed, (sa, se, sm) in enumerate([(1.0, 0.1, 0.0), (1.0, 0.1, 0.05), (3.0, 0.001, 0.0), (3.0, 0.001, 0.05)]):
            x, eta, y = draw(n, 3, 1, length, sa, se, sm, seed)
            auto = log_likelihood(y, eta, x, KERNEL, sa, length, sm, se)
            dense = log_likelihood(y, eta, x, KERNEL, sa, length, sm, se, method="dense")
            worst = max(worst, float((auto - dense).abs().max()))
        ell = torch.tensor([length], dtype=torch.float64)
        m, fits = int(hilbert.sizes(x, KERNEL, ell)[0]), bool(hilbert.fits(x, KERNEL, ell)[0])
        print(f"| {length:g} | {m} | {'reduced rank' if fits else 'dense'} | {worst:.1e} |")


def timing(n: int, repeats: int) -> None:
    print(f"\n### Value and gradient at {n} points, 48 vectors x 4 load cases, σm = 0.05 (CPU s)\n")
    print("| length [m] | basis m | dense | auto | ratio |")
    print("| ---: | ---: | ---: | ---: | ---: |")
    for length in (0.3, 0.6, 1.2, 3.0):
        x, eta, y = draw(n, 4, 48, length, 1.0, 0.1, 0.05, 0)
        seconds: dict[str, list[float]] = {"dense": [], "auto": []}
        for _ in range(repeats):
            for method in seconds:
                e = eta.clone().requires_grad_()
                sa = torch.full((48,), 1.0, dtype=torch.float64, requires_grad=True)
                ell = torch.full((48,), length, dtype=torch.float64, requires_grad=True)
                start = time.process_time()
                value = log_likelihood(y, e, x, KERNEL, sa, ell, 0.05, 0.1, method=method)
                torch.autograd.grad(value.sum(), (e, sa, ell))
                seconds[method].append(time.process_time() - start)
        dense, auto = statistics.median(seconds["dense"]), statistics.median(seconds["auto"])
        m = int(hilbert.sizes(x, KERNEL, torch.tensor([length], dtype=torch.float64))[0])
        print(f"| {length:g} | {m} | {dense:.3f} | {auto:.3f} | {auto / dense:.2f} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[200] if SMOKE else [458, 1000])
    parser.add_argument("--repeats", type=int, default=1 if SMOKE else 3)
    args = parser.parse_args()
    torch.set_num_threads(1)
    print(f"torch {torch.__version__}, 1 thread, load {os.getloadavg()[0]:.1f}, "
          f"KAPPA {hilbert.KAPPA:g}, MARGIN {hilbert.MARGIN:g}, SHARE {hilbert.SHARE:g}")
    for n in args.sizes:
        errors(n)
        timing(n, args.repeats)
    print(f"\nload at the end {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()

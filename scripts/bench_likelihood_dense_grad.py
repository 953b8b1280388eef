"""The dense likelihood's gradient: closed form (torchshm.likelihood.dense) against autograd.

For `B` parameter vectors, `L` load cases and `n` points, Eq. (21) with a squared-exponential
discrepancy, σm = 0.05 (one covariance per load case): the CPU seconds of value + gradient in
the strains (what the emulator's error model and exploration need) and in the strains, σa and
l (what a gradient-based optimiser needs), through ``log_likelihood(method="dense")`` and through
the same Gaussian written with autograd's Cholesky, in the same process, alternating. The
values and gradients are compared. ``TORCHSHM_SMOKE=1``: one small size (a check that it runs).

    OMP_NUM_THREADS=1 python scripts/bench_likelihood_dense_grad.py
"""

from __future__ import annotations

import argparse
import math
import os
import time

import torch

from torchshm.likelihood import log_likelihood

SMOKE = os.environ.get("TORCHSHM_SMOKE") == "1"


def autograd_form(y: torch.Tensor, eta: torch.Tensor, x: torch.Tensor, s: torch.Tensor,
                  ell: torch.Tensor) -> torch.Tensor:
    """Eq. (21), squared exponential, σm = 0.05, σe = 0.1, through autograd's Cholesky."""
    d = (x[:, None] - x[None]).abs()
    k = s[:, None, None] ** 2 * torch.exp(-((d / ell[:, None, None]) ** 2))
    cov = k[:, None] + torch.diag_embed(0.0025 * eta.square() + 0.01)
    chol = torch.linalg.cholesky(cov)
    z = torch.linalg.solve_triangular(chol, (y - eta).unsqueeze(-1), upper=False)
    log_det = 2.0 * chol.diagonal(dim1=-2, dim2=-1).log().sum((-1, -2))
    return -0.5 * (z.square().sum((-1, -2, -3)) + log_det + eta[0].numel() * math.log(2 * math.pi))


def closed_form(y, eta, x, s, ell):  # noqa: ANN001, ANN201 (same signature as above)
    """The library's dense form (closed-form gradient)."""
    return log_likelihood(y, eta, x, "squared_exponential", s, ell, 0.05, 0.1, method="dense")


def timed(form, data, wrt_theta: bool) -> tuple[float, torch.Tensor, list[torch.Tensor]]:  # noqa: ANN001
    """CPU seconds, values and gradients of one call of ``form``."""
    y, eta, x, s, ell = data
    eta = eta.clone().requires_grad_(True)
    s, ell = s.clone().requires_grad_(wrt_theta), ell.clone().requires_grad_(wrt_theta)
    start = time.process_time()
    value = form(y, eta, x, s, ell)
    grads = torch.autograd.grad(value.sum(), (eta, s, ell) if wrt_theta else (eta,))
    return time.process_time() - start, value.detach(), list(grads)


def case(b: int, n_loads: int, n: int, seed: int = 0) -> tuple[torch.Tensor, ...]:
    gen = torch.Generator().manual_seed(seed)
    x = torch.sort(torch.rand(n, generator=gen, dtype=torch.float64) * 30).values
    eta = 50 * torch.randn(b, n_loads, n, generator=gen, dtype=torch.float64)
    y = eta[0] + torch.randn(n_loads, n, generator=gen, dtype=torch.float64)
    s = 1 + 3 * torch.rand(b, generator=gen, dtype=torch.float64)
    ell = 0.5 + 3 * torch.rand(b, generator=gen, dtype=torch.float64)
    return y, eta, x, s, ell


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=5, help="timed calls of each form")
    args = parser.parse_args()
    sizes = [(8, 3, 60)] if SMOKE else [(64, 3, 192), (64, 3, 351), (16, 3, 1000)]
    repeats = 1 if SMOKE else args.repeats
    print(f"torch {torch.__version__}, {torch.get_num_threads()} thread(s); CPU seconds, median "
          f"of {repeats}, the two forms alternating" + (" (smoke: no figures)" if SMOKE else ""))
    print("| B x L x n | gradient in | autograd [s] | closed form [s] | ratio | max rel. diff |")
    print("| --- | --- | ---: | ---: | ---: | ---: |")
    for b, n_loads, n in sizes:
        data = case(b, n_loads, n)
        timed(autograd_form, data, True), timed(closed_form, data, True)  # warm-up, untimed
        for wrt_theta in (False, True):
            times: dict[str, list[float]] = {"auto": [], "closed": []}
            for _ in range(repeats):
                t_auto, v_auto, g_auto = timed(autograd_form, data, wrt_theta)
                t_closed, v_closed, g_closed = timed(closed_form, data, wrt_theta)
                times["auto"].append(t_auto)
                times["closed"].append(t_closed)
            diff = max(float(((a - c).abs().max() / a.abs().max().clamp_min(1e-300)))
                       for a, c in zip([v_auto, *g_auto], [v_closed, *g_closed], strict=True))
            med = {k: sorted(v)[len(v) // 2] for k, v in times.items()}
            what = "η, σa, l" if wrt_theta else "η"
            print(f"| {b} x {n_loads} x {n} | {what} | {med['auto']:.3f} | {med['closed']:.3f} | "
                  f"{med['auto'] / med['closed']:.2f} | {diff:.1e} |")


if __name__ == "__main__":
    main()

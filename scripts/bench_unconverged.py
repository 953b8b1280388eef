"""The emulator method stopped early by a small cap: is its unconverged posterior honest?

Issue 18's point 3: a run that ends at its cap says so, and its posterior is never narrower
than its own error allows. For each case (``benchmarks/``: suite, held-out and second held-out
cases) the method runs with its defaults but a cap of ``n_initial + K`` model runs for each
``K`` of ``--beyond`` (the initial design plus one, two, four batches of 5), and the result is
scored against the case's reference (the same moments as ``bench_identification.py``), over
the parameters the reference identifies:

- ``err/own sd``: the largest |mean − reference mean| in the *method's own* posterior sd. An
  honest posterior has it below about 2 (the reference mean inside its own ±2 sd); above 3 is a
  confidently wrong result;
- ``err/ref sd``: the same in the reference's sd (the accuracy figure of the suite's table);
- ``sd ratio``: the method's sd over the reference's, smallest and largest.

Usage::

    python scripts/bench_unconverged.py [--cases NAME ...] [--beyond 5 10 20] [--out F.json]

One process, one torch thread; prints one markdown table (and ``--out``: its rows as JSON).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import torch

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))

import torchshm  # noqa: E402
from bench_identification import moments  # noqa: E402
from benchmarks.cases import make_problem  # noqa: E402
from benchmarks.holdout import KNOWN  # noqa: E402
from torchshm.inference.adaptive.method import default_n_initial  # noqa: E402

REFS = ROOT / "benchmarks" / "references"
#: one case per flavour: plateau, held-out 2-4 parameters, ridge, two fibres, 6 parameters
DEFAULT_CASES = ["beam2_saturating", "holdout3_p2", "fresh4_p2", "beam3_ridge", "holdout1_p3",
                 "holdout4_p3", "beam4_bridge", "holdout8_p4", "beam6_small_error", "fresh11_p6"]


def one_run(name: str, beyond: int, seed: int) -> dict[str, Any]:
    """The emulator on case ``name`` capped at its initial design plus ``beyond`` runs."""
    case = KNOWN[name]
    ref = json.loads((REFS / f"{name}.json").read_text())
    idx = [ref["names"].index(n) for n in ref["identified"]]
    ref_mean, ref_sd = (m[idx] for m in moments(ref))
    cap = default_n_initial(case.n_physical, 5) + beyond
    problem = make_problem(case)
    t0 = time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        post = torchshm.identify(problem, method="emulator", seed=seed, max_model_evaluations=cap)
    samples = np.asarray(post.samples)[:, idx]
    mean, sd = samples.mean(0), samples.std(0)
    own = np.abs(mean - ref_mean) / sd
    ratio = sd / ref_sd
    return {"case": name, "P": case.n_physical, "cap": cap, "runs": post.n_model_evaluations,
            "converged": bool(post.converged), "err_own_sd": float(own.max()),
            "worst": ref["identified"][int(np.argmax(own))],
            "err_ref_sd": float((np.abs(mean - ref_mean) / ref_sd).max()),
            "sd_ratio_min": float(ratio.min()), "sd_ratio_max": float(ratio.max()),
            "averaged": post.diagnostics.get("averaged_over_errors"),  # ESS, points, draws
            "cpu_s": time.process_time() - t0}


def table(rows: list[dict[str, Any]]) -> str:
    """The rows as one markdown table."""
    lines = ["| case | P | cap | runs | converged | err / own sd (parameter) | err / ref sd | sd ratio |",
             "| --- | ---: | ---: | ---: | --- | ---: | ---: | --- |"]
    for r in rows:
        lines.append(f"| {r['case']} | {r['P']} | {r['cap']} | {r['runs']} | "
                     f"{'yes' if r['converged'] else 'no'} | {r['err_own_sd']:.2f} ({r['worst']}) | "
                     f"{r['err_ref_sd']:.2f} | {r['sd_ratio_min']:.2f}–{r['sd_ratio_max']:.2f} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cases", nargs="+", default=DEFAULT_CASES, choices=list(KNOWN))
    parser.add_argument("--beyond", nargs="+", type=int, default=[5, 10, 20],
                        help="runs allowed past the initial design")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, help="JSON file of the rows, rewritten after every run")
    args = parser.parse_args(argv)
    torch.set_num_threads(1)
    print(f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, load average "
          f"{', '.join(f'{x:.1f}' for x in os.getloadavg())}", flush=True)
    rows = []
    for name in args.cases:
        for beyond in args.beyond:
            rows.append(one_run(name, beyond, args.seed))
            print(json.dumps(rows[-1]), flush=True)
            if args.out is not None:
                args.out.write_text(json.dumps(rows, indent=1))
    print(table(rows))
    print(f"load average at the end {', '.join(f'{x:.1f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()

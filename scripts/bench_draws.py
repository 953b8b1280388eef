"""The emulator's returned draws: one importance pass against the pooled passes, on one emulator.

The final step of ``method="emulator"`` (``torchshm/inference/adaptive/draws.py``) draws the
posterior by importance sampling from a mixture fitted to the last chain; where the weights
leave a parameter's mean or sd uncertain (a long tail that the slabs reach) it draws up to two
more passes and pools them. The rounds before are the same either way, so each case runs the
emulator once with its defaults (one torch thread), keeps its last emulated log joint and chain,
and then makes the final draws at ``--seeds`` seeds both ways: ``one`` (the first pass alone, as
before 2026-11-30) and ``pooled`` (the library's). Each is scored against the case's reference
as ``scripts/bench_identification.py`` scores a row (max |Δmean|/sd and the sd ratio range over
the parameters the reference identifies). One JSON row per case and way; then a table.

    OMP_NUM_THREADS=1 python scripts/bench_draws.py --cases sixth6_p4 sixth3_p5 --seeds 5
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import torch

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))

import bench_identification  # noqa: E402
import torchshm  # noqa: E402
from benchmarks.cases import make_problem  # noqa: E402
from benchmarks.holdout import KNOWN  # noqa: E402
from torchshm.inference.adaptive import draws as final_draws  # noqa: E402
from torchshm.inference.adaptive import final  # noqa: E402


def capture(case: str, options: dict) -> tuple[dict, dict]:
    """Run the emulator on ``case`` and keep the arguments of its final draws."""
    kept: dict = {}
    original = final.posterior_draws

    def keep(log_joint, chain, hard, plausible, n, seed):  # noqa: ANN001, ANN202
        kept.update(log_joint=log_joint, chain=chain, hard=hard, plausible=plausible, n=n)
        return original(log_joint, chain, hard, plausible, n, seed)

    final.posterior_draws = keep
    try:
        t = time.process_time()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            post = torchshm.identify(make_problem(KNOWN[case]), method="emulator", seed=0, **options)
        run = {"runs": post.n_model_evaluations, "converged": post.converged,
               "cpu_s": time.process_time() - t}
    finally:
        final.posterior_draws = original
    return kept, run


def draw(kept: dict, seed: int, passes: bool) -> tuple[np.ndarray, dict, float]:
    """The final draws `n x D` at ``seed``, pooled passes or the first alone, with their
    information and CPU time."""
    most = final_draws.MAX_PASSES
    final_draws.MAX_PASSES = most if passes else 0
    try:
        t = time.process_time()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            result, _, _, info = final_draws.posterior_draws(
                kept["log_joint"], kept["chain"], kept["hard"], kept["plausible"], kept["n"], seed)
        return result.draws, info, time.process_time() - t
    finally:
        final_draws.MAX_PASSES = most


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="+", required=True, choices=list(KNOWN))
    parser.add_argument("--seeds", type=int, default=5, help="seeds of the final draws per case")
    parser.add_argument("--options", type=json.loads, default={}, metavar="JSON",
                        help='keyword options of method="emulator" (default: none)')
    args = parser.parse_args()
    torch.set_num_threads(1)
    rows = []
    for case in args.cases:
        ref = json.loads((ROOT / "benchmarks" / "references" / f"{case}.json").read_text())
        kept, run = capture(case, args.options)
        for way in ("one", "pooled"):
            scores, passes, cpu = [], [], []
            for seed in range(args.seeds):
                d, info, seconds = draw(kept, seed, way == "pooled")
                scores.append(bench_identification.score(
                    {"mean": d.mean(0).tolist(), "sd": d.std(0).tolist()}, ref))
                passes.append(info["importance_passes"])
                cpu.append(seconds)
            row = {"case": case, "way": way, **run, "seeds": args.seeds,
                   "max_dmean_sd": max(s["max_dmean_sd"] for s in scores),
                   "sd_ratio_min": min(s["sd_ratio_min"] for s in scores),
                   "sd_ratio_max": max(s["sd_ratio_max"] for s in scores),
                   "passes": [int(p) for p in passes], "draws_cpu_s": float(np.median(cpu))}
            rows.append(row)
            print("ROW", json.dumps(row), flush=True)
    print("\n| case | runs | way | max \\|Δmean\\|/sd (worst seed) | sd ratio (all seeds) "
          "| passes after the first | CPU s of the draws (median) |")
    print("| --- | ---: | --- | ---: | --- | --- | ---: |")
    for r in rows:
        print(f"| {r['case']} | {r['runs']} | {r['way']} | {r['max_dmean_sd']:.2f} | "
              f"{r['sd_ratio_min']:.2f}–{r['sd_ratio_max']:.2f} | {','.join(map(str, r['passes']))} "
              f"| {r['draws_cpu_s']:.1f} |")


if __name__ == "__main__":
    main()

"""Where the emulator method's own compute goes on the main job (bridge 705 surrogate, 351
strains, Matérn 3/2, paper priors): CPU seconds of ``identify`` split by step.

    python scripts/bench_emulator_cost.py [--threads 1] [--seed 0] [--split]

Run it from two checkouts side by side (e.g. a ``git worktree`` at an older commit) to compare.
The model is the shipped GP surrogate, so model time is negligible and the figure is the
method's own: field-emulator fits, emcee on the emulated likelihood, the final density and
evidence. CPU times (``time.process_time``: every thread of the process) are reported beside
the wall time and the load.
"""

from __future__ import annotations

import argparse
import cProfile
import json
import os
import pstats
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's torchshm

#: functions whose cumulative time is reported, by a part of their qualified name
STEPS = {
    "field emulator fits": "adaptive/field.py:fit",
    "chains (emcee on the emulated likelihood)": "adaptive/sampling.py:run_chain",
    "mode search": "adaptive/modes.py:find_modes",
    "mixture density (stored)": "adaptive/sampling.py:fit_density",
    "importance proposal (full-covariance mixture)": "adaptive/mixture.py:fit_mixture",
    "evidence (importance sampling)": "adaptive/sampling.py:importance",
    "batch choice": "adaptive/acquisition.py:choose_batch",
    "batch check": "adaptive/validation.py:check_batch",
    "model runs": "adaptive/runs.py:run_batch",
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--split", action="store_true",
                        help="profile the steps (adds the profiler's own overhead to the total)")
    args = parser.parse_args()
    import torch

    torch.set_num_threads(args.threads)
    import torchshm

    model = torchshm.bridge705_surrogate()
    data = torchshm.synthetic_campaign(seed=0).select([39.8])
    problem = torchshm.Problem(model, data, kernel="matern32")
    profile = cProfile.Profile(time.process_time)
    wall, cpu = time.perf_counter(), time.process_time()
    if args.split:
        profile.enable()
    post = torchshm.identify(problem, "emulator", seed=args.seed)
    profile.disable()
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    stats = pstats.Stats(profile).stats if args.split else {}  # (file, line, name) -> (.., ct, ..)
    parts = {}
    for label, key in STEPS.items():
        where, name = key.split(":")
        parts[label] = sum(v[3] for k, v in stats.items() if k[0].endswith(where) and k[2] == name)
    rounds = post.diagnostics.get("n_rounds", 0)
    print(json.dumps({
        "commit": os.popen("git rev-parse --short HEAD").read().strip(),
        "load": os.getloadavg()[0], "threads": args.threads, "model_runs": post.n_model_evaluations,
        "rounds": rounds, "converged": post.converged, "cpu_s": round(cpu, 2),
        "cpu_per_round_s": round(cpu / max(rounds, 1), 2), "wall_s": round(wall, 2),
        "round_cpu_s": [round(r["cpu_time_s"], 2) for r in post.diagnostics["rounds"]],
        "final_cpu_s": round(post.diagnostics["final_cpu_time_s"], 2),
        "steps_cpu_s": {k: round(v, 2) for k, v in parts.items()},
        "E_c": [round(float(post.summary()["E_c"].mean), 3), round(float(post.summary()["E_c"].sd), 3)],
        "log_evidence": round(float(post.log_evidence), 3),
    }, indent=1))


if __name__ == "__main__":
    main()

"""Study A of the paper (Sec. 4, Tables 3 and 5, Figs. 4-6): VBMC against emcee.

    python scripts/study_a.py [--out runs/study_a] [--emcee-steps 2000] [overrides ...]

Runs VBMC (sub-case A2) and emcee (A1, 40 walkers x 2000 steps) on the problem of
``torchshm-identify`` (default: matern32, load case 39.8 m, surrogate model, shipped campaign,
0.1 m resolution; ``overrides`` such as ``resolution=0.5`` apply to both runs) and writes
Table 5, Figs. 4-6 and the convergence numbers into ``--out``. Takes about 10 minutes on two
cores with the defaults. An interrupted emcee chain is continued with ``--resume``.
"""

from __future__ import annotations

import argparse
import json
import logging
from pathlib import Path

from torchshm.cli.errors import report_bad_input
from torchshm.cli.study_a import StudyABudget, run_study_a


def parse_args(argv: list[str] | None = None) -> tuple[argparse.Namespace, list[str]]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("runs/study_a"), help="output folder")
    parser.add_argument("--vbmc-max-fun-evals", type=int, default=None, help="VBMC budget")
    parser.add_argument("--emcee-walkers", type=int, default=40)
    parser.add_argument("--emcee-steps", type=int, default=2000)
    parser.add_argument("--window", type=int, default=1000, help="samples per Fig. 5 estimate")
    parser.add_argument("--tol", type=float, default=0.1, help="stabilisation tolerance [sd]")
    parser.add_argument("--resume", action="store_true", help="continue the emcee chain")
    parser.add_argument("overrides", nargs="*", help="torchshm-identify overrides for both runs")
    args = parser.parse_args(argv)
    return args, list(args.overrides)


def main(argv: list[str] | None = None) -> None:
    args, overrides = parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="[%(asctime)s][%(name)s] %(message)s")
    logging.captureWarnings(True)
    budget = StudyABudget(args.vbmc_max_fun_evals, args.emcee_walkers, args.emcee_steps,
                          args.window, args.tol)
    with report_bad_input("study_a.py"):
        numbers = run_study_a(overrides, args.out, budget, resume=args.resume)
    print((args.out / "study_a.md").read_text())
    print(json.dumps({k: numbers[k] for k in ("comparison", "emcee_samples_over_vbmc_evaluations")}, indent=2))


if __name__ == "__main__":
    main()

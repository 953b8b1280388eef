"""Study A of the paper (Sec. 4, Tables 3 and 5, Figs. 4-6): VBMC against emcee.

    python studies/study_a.py [--out runs/study_a] [--emcee-steps 2000] [overrides ...]

Runs VBMC (sub-case A2) and emcee (A1, 40 walkers x 2000 steps) on the problem of
``torchshm-identify`` (default: matern32, load case 39.8 m, surrogate model, shipped campaign,
0.1 m resolution; ``overrides`` such as ``resolution=0.5`` apply to both runs) and writes
Table 5, Figs. 4-6 and the convergence numbers into ``--out``. Takes about 10 minutes on two
cores with the defaults. An interrupted emcee chain is continued with ``--resume``.

The steps of :func:`run_study_a`: compose the configuration of ``torchshm-identify`` twice
(``method=vbmc`` and ``method=emcee``, the same other overrides), identify with each method on
its own :class:`~torchshm.Problem`, then hand both posteriors and the full emcee chain to
``study_a_report.py`` (beside this file), which writes Table 5, Figs. 4-6 and the convergence
numbers.
"""

from __future__ import annotations

import argparse
import json
import logging
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from torchshm.cli.errors import report_bad_input
from torchshm.cli.job import build_model, build_problem, load_data
from torchshm.config import (
    CONF_DIR,
    CONFIG_NAME,
    Config,
    build_priors,
    method_options,
    normalize_overrides,
    register_configs,
    to_settings,
)

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class StudyABudget:
    """Budgets of the two runs (defaults: the paper's settings) and the convergence tolerance.

    Attributes:
        vbmc_max_fun_evals: VBMC evaluation budget; None = PyVBMC's default.
        emcee_walkers: emcee walkers (paper: 40).
        emcee_steps: emcee steps per walker (paper: 2000).
        window: samples behind each point of the Fig. 5 trace (paper: the last 1,000).
        tol: stabilisation tolerance in posterior standard deviations.
    """

    vbmc_max_fun_evals: int | None = None
    emcee_walkers: int = 40
    emcee_steps: int = 2000
    window: int = 1000
    tol: float = 0.1


@dataclass
class StudyARun:
    """One method's run: its settings, posterior and wall time [s]."""

    settings: Config
    posterior: Any
    wall_time_s: float


def compose_settings(overrides: Sequence[str], method_overrides: Sequence[str]) -> Config:
    """Typed settings of ``torchshm-identify`` for ``overrides`` plus ``method_overrides``."""
    from hydra import compose, initialize_config_dir

    register_configs()
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        cfg = compose(CONFIG_NAME, overrides=normalize_overrides([*overrides, *method_overrides]))
    return to_settings(cfg)


def study_settings(overrides: Sequence[str], budget: StudyABudget) -> tuple[Config, Config]:
    """The VBMC and emcee settings of the study (A2 and A1)."""
    vbmc = ["method=vbmc"]
    if budget.vbmc_max_fun_evals is not None:
        vbmc.append(f"method.max_fun_evals={budget.vbmc_max_fun_evals}")
    emcee = ["method=emcee", f"method.n_walkers={budget.emcee_walkers}",
             f"method.n_steps={budget.emcee_steps}", f"method.window={budget.window}"]
    return compose_settings(overrides, vbmc), compose_settings(overrides, emcee)


def identify_with(settings: Config, measurements: Any, base: Path, log_dir: Path,
                  **extra: Any) -> StudyARun:
    """Identify with ``settings.method`` on a fresh problem; ``extra`` adds method options."""
    import torchshm

    problem = build_problem(settings, build_model(settings, base), measurements, base,
                            build_priors(settings.priors))
    t0 = time.perf_counter()
    post = torchshm.identify(problem, method=settings.method.name, seed=settings.seed,
                             log_dir=log_dir, **{**method_options(settings.method), **extra})
    return StudyARun(settings, post, time.perf_counter() - t0)


def read_chain(path: Path) -> np.ndarray:
    """The full `S x W x D` chain of an emcee HDF5 backend file (its only group)."""
    import emcee
    import h5py

    with h5py.File(path, "r") as f:
        (group,) = list(f.keys())
    return np.asarray(emcee.backends.HDFBackend(str(path), name=group, read_only=True).get_chain())


def run_study_a(overrides: Sequence[str], out_dir: Path, budget: StudyABudget = StudyABudget(),
                base: Path | None = None, resume: bool = False) -> dict[str, Any]:
    """Run study A and write its outputs into ``out_dir``.

    Args:
        overrides: ``torchshm-identify`` overrides shared by both runs (e.g. ``resolution=0.5``).
        out_dir: output folder (``runs/study_a``).
        budget: the runs' budgets and the stabilisation tolerance.
        base: directory relative paths in the overrides resolve against (default: cwd).
        resume: continue the emcee chain of ``out_dir/emcee_chain.h5`` instead of restarting.

    Returns:
        The study's numbers (also written to ``out_dir/study_a.json``).
    """
    from study_a_report import write_report

    base = Path.cwd() if base is None else base
    out_dir.mkdir(parents=True, exist_ok=True)
    vbmc_settings, emcee_settings = study_settings(overrides, budget)
    measurements = load_data(vbmc_settings.data, base)
    chain_path = out_dir / "emcee_chain.h5"
    if chain_path.exists() and not resume:
        chain_path.unlink()
    log.info("study A: VBMC (A2)")
    vbmc = identify_with(vbmc_settings, measurements, base, out_dir / "tb" / "vbmc")
    log.info("study A: emcee (A1), %d walkers x %d steps", budget.emcee_walkers, budget.emcee_steps)
    emcee = identify_with(emcee_settings, measurements, base, out_dir / "tb" / "emcee",
                          backend_path=chain_path)
    return write_report(vbmc, emcee, read_chain(chain_path), measurements.attrs, budget, out_dir)


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

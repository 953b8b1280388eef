"""Reference posteriors of the benchmark suite, cached as small JSON files.

For each case of :mod:`benchmarks.cases`: the MAP from several starts (the truth, prior draws
and the case's extra starts; their agreement is reported), emcee from each distinct mode on the
model's own likelihood until the kept chain exceeds 50 autocorrelation times, and importance
sampling from a mixture of widened Student-t's for the log evidence, its sd and ESS, and the
posterior weight of each mode. Moments and quantiles come from the chains, modes weighted by
the importance weights. Written to ``benchmarks/references/<case>.json`` with the case's
definition hash (:func:`benchmarks.cases.case_hash`) and the git commit.

Usage (from the repository root)::

    OMP_NUM_THREADS=1 python scripts/make_references.py --all
    OMP_NUM_THREADS=1 python scripts/make_references.py --case beam2_saturating --case plate2_field
    OMP_NUM_THREADS=1 python scripts/make_references.py --holdout  # the held-out cases
    OMP_NUM_THREADS=1 python scripts/make_references.py --fresh  # the second held-out set
    OMP_NUM_THREADS=1 python scripts/make_references.py --third  # the third held-out set
    OMP_NUM_THREADS=1 python scripts/make_references.py --edge   # the fourth: 1, 7, 8 parameters
    OMP_NUM_THREADS=1 python scripts/make_references.py --fifth  # the fifth: 2, 3, 4, 6 parameters
    OMP_NUM_THREADS=1 python scripts/make_references.py --sixth  # the sixth: the same, another seed
    OMP_NUM_THREADS=1 python scripts/make_references.py --seventh  # the seventh: the same, another seed
    OMP_NUM_THREADS=1 python scripts/make_references.py --eighth  # the eighth: the same, another seed
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import torch

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks.cases import Case, case_hash, make_problem, truth_vector  # noqa: E402
from benchmarks.catalog import CASES  # noqa: E402
from benchmarks.holdout import HELD_OUT, KNOWN  # noqa: E402
from benchmarks.reference import direct_log_joint, find_modes, importance, run_chain  # noqa: E402

OUT = ROOT / "benchmarks" / "references"
QUANTILES = (0.025, 0.16, 0.5, 0.84, 0.975)
SMOKE = os.environ.get("TORCHSHM_SMOKE") == "1"  # tiny sizes: a check that it runs (docs test), no figures


def weighted_summary(samples: np.ndarray, weights: np.ndarray) -> dict[str, list]:
    """Mean, sd, quantiles and correlation matrix of weighted samples `S x D`."""
    w = weights / weights.sum()
    mean = w @ samples
    cov = (samples - mean).T @ ((samples - mean) * w[:, None])
    sd = np.sqrt(np.diag(cov))
    qs = []
    for j in range(samples.shape[1]):
        order = np.argsort(samples[:, j])
        cdf = np.cumsum(w[order])
        qs.append([float(samples[order, j][min(np.searchsorted(cdf, q), len(cdf) - 1)]) for q in QUANTILES])
    return {"mean": mean.tolist(), "sd": sd.tolist(), "quantiles": qs,
            "corr": np.round(cov / np.outer(sd, sd), 3).tolist()}


def reference(case: Case, seed: int = 1, n_importance: int = 20000, max_steps: int = 20000,
              n_box: int = 6, chunk: int = 500) -> dict:
    """The reference of one case (JSON-ready): the MAP from the truth and ``n_box`` random
    points of the plausible box, emcee from each mode in chunks of ``chunk`` steps (at most
    ``max_steps``), importance sampling with ``n_importance`` draws."""
    t0 = time.process_time()
    problem = make_problem(case)
    names = list(problem.names)
    log_joint = direct_log_joint(problem)
    check = np.vstack([problem.sample_prior(8, np.random.default_rng(seed)), truth_vector(case, names)])
    a, b = log_joint(check), np.asarray(problem.log_joint(check))
    assert np.allclose(a[np.isfinite(b)], b[np.isfinite(b)], rtol=1e-9, atol=1e-6), (a, b)
    plaus = np.asarray(problem.plausible_bounds)
    scale = plaus[:, 1] - plaus[:, 0]
    truth = truth_vector(case, names)
    extra = [truth.copy() for _ in case.extra.get("starts", [])]
    for row, over in zip(extra, case.extra.get("starts", [])):
        row[[names.index(k) for k in over]] = list(over.values())
    rng = np.random.default_rng([seed, 2])
    box = plaus[:, 0] + rng.random((n_box, len(names))) * scale
    starts = np.vstack([truth[None], box, *[e[None] for e in extra]])
    modes, optima = find_modes(log_joint, np.asarray(problem.hard_bounds), scale, starts)
    t_map = time.process_time() - t0
    chains = [run_chain(log_joint, m, scale, np.asarray(problem.hard_bounds), seed + 10 * i, chunk=chunk,
                        max_steps=max_steps)
              for i, m in enumerate(modes)]
    samples = [c.pop("samples") for c in chains]
    imp = importance(log_joint, samples, n_importance, seed)
    imp.pop("draws"), imp.pop("weights")
    weights = np.concatenate([np.full(len(s), mw / len(s)) for s, mw in zip(samples, imp["mode_weights"])])
    summary = weighted_summary(np.vstack(samples), weights)
    prior_sd = problem.sample_prior(20000, np.random.default_rng(seed)).std(0)
    within = np.max([s.std(0) for s in samples], axis=0)  # sd inside each mode: a mode's width
    identified = [n for n, s, p in zip(names, within, prior_sd) if s < 0.5 * p and n not in case.unidentified]
    commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True).stdout.strip()
    return {"case": case.name, "case_hash": case_hash(case), "commit": commit, "seed": seed, "names": names,
            "truth": truth.tolist(), **summary, "prior_sd": prior_sd.tolist(), "identified": identified,
            "map": {"modes": [m.tolist() for m in modes], "optimum_per_start": [round(v, 3) for v in optima],
                    "n_starts": len(starts), "starts_within_0.5_nats": int(np.sum(np.array(optima) > optima[0] - 0.5)),
                    "cpu_s": round(t_map, 1)},
            "chains": chains, "importance": imp, "mode_means": [np.round(s.mean(0), 5).tolist() for s in samples],
            "mode_sds": [np.round(s.std(0), 5).tolist() for s in samples],
            "settings": {"moves": "DE 0.8 + DE gamma=1 0.2", "n_tau": 50, "burn": "max(300, 5 tau)",
                         "proposal": "equal mixture of multivariate t (df 4), 1.5 x chain sd, one per mode"},
            "cpu_s": round(time.process_time() - t0, 1)}


def rehash(name: str) -> None:
    """Renew the hash of ``name``'s reference if its log joint at the MAP is unchanged."""
    path = OUT / f"{name}.json"
    if not path.exists():
        print(f"{name}: no reference")
        return
    ref = json.loads(path.read_text())
    value = float(direct_log_joint(make_problem(KNOWN[name]))(np.asarray(ref["map"]["modes"][0]))[0])
    if abs(value - ref["map"]["optimum_per_start"][0]) > 1e-3:
        print(f"{name}: changed (log joint at the MAP {value:.3f}, was {ref['map']['optimum_per_start'][0]})")
        return
    ref["case_hash"] = case_hash(KNOWN[name])
    path.write_text(json.dumps(ref, indent=1) + "\n")
    print(f"{name}: unchanged, hash {ref['case_hash']}")


def _names(args: argparse.Namespace) -> list[str]:
    """The cases the command line names: a whole set (``--all``, ``--holdout``, ``--fresh``,
    ``--third``, ``--edge``, ``--fifth``, ``--sixth``, ``--seventh``, ``--eighth``) or the ``--case`` ones."""
    if args.all:
        return list(CASES)
    chosen = [list(cases) for flag, cases in HELD_OUT.items() if getattr(args, flag)]
    return chosen[0] if chosen else list(args.case)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--case", action="append", default=[], choices=list(KNOWN))
    parser.add_argument("--all", action="store_true", help="every case of the suite")
    parser.add_argument("--holdout", action="store_true", help="every held-out case (benchmarks/holdout.py)")
    parser.add_argument("--fresh", action="store_true", help="every case of the second held-out set (FRESH)")
    parser.add_argument("--third", action="store_true", help="every case of the third held-out set (THIRD)")
    parser.add_argument("--edge", action="store_true", help="every case of the fourth held-out set (EDGE: "
                        "1, 7 and 8 physical parameters)")
    parser.add_argument("--fifth", action="store_true", help="every case of the fifth held-out set (FIFTH: "
                        "2, 3, 4 and 6 physical parameters, drawn 2026-11-29)")
    parser.add_argument("--sixth", action="store_true", help="every case of the sixth held-out set (SIXTH: "
                        "2, 3, 4 and 6 physical parameters, drawn 2026-11-29 22:00 UTC)")
    parser.add_argument("--seventh", action="store_true", help="every case of the seventh held-out set (SEVENTH: "
                        "2, 3, 4 and 6 physical parameters, drawn 2026-12-01 21:25 UTC)")
    parser.add_argument("--eighth", action="store_true", help="every case of the eighth held-out set (EIGHTH: "
                        "2, 3, 4 and 6 physical parameters, drawn 2026-12-02 03:30 UTC)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--rehash", action="store_true", help="only renew the definition hash of existing "
                        "references whose problem is unchanged (same log joint at their MAP, to 1e-3 nats)")
    args = parser.parse_args()
    torch.set_num_threads(1)
    OUT.mkdir(parents=True, exist_ok=True)
    if args.rehash:
        for name in _names(args):
            rehash(name)
        return
    names, out, budget = _names(args), OUT, {}
    if SMOKE:  # written beside the references, never over them
        names, out = names[:1], OUT / "smoke"
        budget = {"n_importance": 500, "max_steps": 200, "chunk": 200, "n_box": 1}
        out.mkdir(exist_ok=True)
        print(f"TORCHSHM_SMOKE=1: {names} only, short chains, into {out}: a check that the script runs")
    for name in names:
        ref = reference(KNOWN[name], args.seed, **budget)
        (out / f"{name}.json").write_text(json.dumps(ref, indent=1) + "\n")
        c = ref["chains"]
        print(f"{name}: modes {len(c)}, tau max {max(max(x['tau']) for x in c):.0f}, steps {c[0]['steps']}, "
              f"n/tau {min(x['n_over_tau'] for x in c):.0f}, log Z {ref['importance']['log_evidence']:.2f} "
              f"± {ref['importance']['log_evidence_sd']:.3f}, ESS {ref['importance']['ess']:.0f}, "
              f"cpu {ref['cpu_s']} s", flush=True)


if __name__ == "__main__":
    main()

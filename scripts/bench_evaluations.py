"""Model runs needed by method="emulator" against VBMC and a long emcee reference.

Parts (``--part``, results cached as JSON under ``runs/bench_evaluations/``, the table written
into ``docs/benchmarks.md`` between its ``bench_evaluations`` markers):

- ``bridge``: study A's case on the FE model ``bridge705()`` itself, Matérn 3/2, load 39.8 m:
  the emulator method, PyVBMC and a long emcee chain (the reference) on the same problem.
- ``four``: a four-parameter beam (``scripts/beam4.py``), the emulator from an empty store
  against the reference of ``four_reference`` (``scripts/beam4_reference.py``: emcee from the
  MAP on the model's own likelihood, and importance sampling), all six parameters.
- ``four_reference``: that reference alone (cached; the slow part of ``four``).
- ``studyb``: the five kernels of study B identified by the emulator from one shared store.

Wall time with a 10-minute model and 5 workers is computed from the round structure: a batch of
b runs takes ceil(b / 5) model times; VBMC's starting design is one batch and every later point
is evaluated after the previous one (PyVBMC acquires sequentially).

Usage: ``python scripts/bench_evaluations.py --part bridge four studyb [--write]``; a part not
named is taken from its cached JSON, so ``--part four --write`` reruns only the four-parameter
case and rewrites the whole table.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import torchshm  # noqa: E402

OUT = Path("runs/bench_evaluations")
MODEL_MIN, WORKERS = 10.0, 5
#: log10 Bayes factors over matern32 from VBMC's ELBOs, study B (docs/results.md, Table 9 analog)
VBMC_BF = {"independent": -127.2, "exponential": -13.0, "matern32": 0.0, "matern52": 2.2,
           "squared_exponential": 3.7}
SHARED_RUNS = 40  # study B: all five kernels from one store of at most this many FE runs
STUDY_B = ("independent", "exponential", "matern52", "squared_exponential")
PER_KERNEL = 2  # new runs each of the four allowed after part bridge's 30: 38 in all


def _summary(post: torchshm.Posterior) -> dict[str, list[float]]:
    s = post.summary()
    return {"mean": [r.mean for r in s.rows], "sd": [r.sd for r in s.rows],
            "names": [r.name for r in s.rows]}


def _emulator_row(post: torchshm.Posterior, wall: float) -> dict[str, object]:
    rounds = post.diagnostics["rounds"]
    hours = sum(math.ceil(r["n_runs"] / WORKERS) for r in rounds) * MODEL_MIN / 60
    return {"runs": post.diagnostics["n_emulator_runs"], "new_runs": post.n_model_evaluations,
            "rounds": len(rounds), "converged": post.converged,
            "sim_hours": hours, "wall_s": wall, "log_evidence": post.log_evidence,
            "log_evidence_sd": post.log_evidence_sd, **_summary(post),
            "per_round": [{k: r[k] for k in ("n_runs", "n_new_runs", "tv", "mmtv", "emulator_share",
                                                "emulator_loglik_sd")} for r in rounds]}


def _reference(problem: object, name: str, n_steps: int) -> dict[str, object]:
    path = OUT / f"reference_{name}.json"
    if path.exists():
        return json.loads(path.read_text())
    t = time.perf_counter()
    post = torchshm.identify(problem, method="emcee", seed=1, n_walkers=32, n_steps=n_steps)
    row = {**_summary(post), "steps": n_steps, "n_over_tau": post.diagnostics["n_over_tau"],
           "wall_s": time.perf_counter() - t}
    path.write_text(json.dumps(row, indent=1))
    return row


def _compare(emu: dict, ref: dict) -> dict[str, float]:
    m, s = np.array(emu["mean"]), np.array(emu["sd"])
    rm, rs = np.array(ref["mean"]), np.array(ref["sd"])
    return {"max_mean_dev_sd": float(np.max(np.abs(m - rm) / rs)),
            "max_sd_rel": float(np.max(np.abs(s / rs - 1)))}


def part_bridge() -> dict[str, object]:
    data = torchshm.synthetic_campaign(seed=0).select([39.8])
    store = OUT / "bridge_store.sqlite"
    problem = torchshm.Problem(torchshm.bridge705(), data, kernel="matern32", store=store)
    t = time.perf_counter()
    post = torchshm.identify(problem, method="emulator", seed=0, batch_size=5,
                             max_model_evaluations=30, n_walkers=16, n_steps=200)
    emu = _emulator_row(post, time.perf_counter() - t)
    emu["exact_is"] = _exact_importance(post, data)
    ref = part_reference()
    vbmc_path = OUT / "vbmc_bridge.json"
    if vbmc_path.exists():
        vb = json.loads(vbmc_path.read_text())
    else:
        t = time.perf_counter()
        vpost = torchshm.identify(torchshm.Problem(torchshm.bridge705(), data,
                                                   kernel="matern32"), method="vbmc", seed=0)
        n = vpost.n_model_evaluations
        n_design = 10  # the starting Latin hypercube, one batch; everything after is sequential
        vb = {"runs": n, "rounds": math.ceil(n_design / WORKERS) + n - n_design,
              "converged": vpost.converged, "wall_s": time.perf_counter() - t,
              "log_evidence": vpost.log_evidence, "log_evidence_sd": vpost.log_evidence_sd,
              **_summary(vpost)}
        vb["sim_hours"] = vb["rounds"] * MODEL_MIN / 60
        vbmc_path.write_text(json.dumps(vb, indent=1))
    return {"emulator": emu, "reference": ref, "vbmc": vb,
            "emulator_vs_ref": _compare(emu, ref), "vbmc_vs_ref": _compare(vb, ref)}


def _exact_importance(post: torchshm.Posterior, data: object) -> dict[str, object]:
    """Posterior moments and evidence by importance sampling with the FE model's own likelihood
    from the emulator's (widened) posterior density: a second, independent reference."""
    from torchshm.inference.adaptive.sampling import importance

    exact = torchshm.Problem(torchshm.bridge705(), data, kernel="matern32")
    log_z, sd, ess, draws = importance(lambda t: np.asarray(exact.log_joint(t)),
                                       post.variational, 8000, 5)
    return {"log_evidence": log_z, "log_evidence_sd": sd, "ess": ess,
            "mean": draws.mean(0).tolist(), "sd": draws.std(0, ddof=1).tolist()}


def part_reference() -> dict[str, object]:
    """The long emcee chain on the FE model (cached: run it alone, beside the other parts)."""
    data = torchshm.synthetic_campaign(seed=0).select([39.8])
    return _reference(torchshm.Problem(torchshm.bridge705(), data, kernel="matern32"), "bridge",
                      2000)


def part_four_reference() -> dict[str, object]:
    """The beam's reference posterior: emcee from the MAP and importance sampling (cached)."""
    from beam4_reference import reference

    path = OUT / "reference_four_map.json"
    if not path.exists():
        path.write_text(json.dumps(reference(), indent=1))
    return json.loads(path.read_text())


def part_four() -> dict[str, object]:
    """The emulator on the four-parameter beam from an empty store, against the reference."""
    from beam4 import beam4_problem

    store = OUT / "four_store.sqlite"
    store.unlink(missing_ok=True)  # every run counts: the emulator starts from no runs
    t = time.perf_counter()
    post = torchshm.identify(beam4_problem(store=store), method="emulator", seed=0,
                             batch_size=5, max_model_evaluations=60, n_steps=200)
    emu = _emulator_row(post, time.perf_counter() - t)
    ref = part_four_reference()
    return {"emulator": emu, "reference": ref, "emulator_vs_ref": _compare(emu, ref),
            "emulator_vs_importance": _compare(emu, ref["importance"]),
            "importance_vs_ref": _compare(ref["importance"], ref)}


def part_studyb(kernels: tuple[str, ...] = STUDY_B) -> dict[str, object]:
    """The other four kernels on the store of part ``bridge`` (whose run is the matern32 row).

    Each kernel may add ``PER_KERNEL`` runs, so that the four together stay within
    ``SHARED_RUNS`` (the kernels can then run side by side, one process each).
    """
    data = torchshm.synthetic_campaign(seed=0).select([39.8])
    store = OUT / "bridge_store.sqlite"  # shared with part bridge: its runs are reused
    out: dict[str, object] = {}
    for kernel in kernels:
        problem = torchshm.Problem(torchshm.bridge705(), data, kernel=kernel, store=store)
        t = time.perf_counter()
        post = torchshm.identify(problem, method="emulator", seed=0, batch_size=5,
                                 max_model_evaluations=PER_KERNEL, n_walkers=16, n_steps=100)
        out[kernel] = _emulator_row(post, time.perf_counter() - t)
        path = OUT / f"studyb_{kernel}.json"
        path.write_text(json.dumps(out[kernel], indent=1, default=float))
    return out


def _four_table(f: dict) -> list[str]:
    """Rows of the four-parameter beam: every parameter, emulator against both references."""
    emu, ref = f["emulator"], f["reference"]
    imp = ref["importance"]
    lines = [f"Four physical parameters (`scripts/beam4.py`): emulator {emu['runs']} runs in "
             f"{emu['rounds']} rounds (converged: {emu['converged']}), log evidence "
             f"{emu['log_evidence']:.3f} ± {emu['log_evidence_sd']:.3f} (importance sampling on "
             f"the model: {imp['log_evidence']:.3f}).", "",
             "| beam4 parameter | emcee from the MAP | importance sampling | emulator | "
             "mean dev. / ref. sd | sd rel. dev. |", "|---|---|---|---|---|---|"]
    for i, name in enumerate(ref["names"]):
        r, s, e = (ref["mean"][i], ref["sd"][i]), (imp["mean"][i], imp["sd"][i]), \
            (emu["mean"][i], emu["sd"][i])
        lines.append(f"| {name} | {r[0]:.5g} ± {r[1]:.3g} | {s[0]:.5g} ± {s[1]:.3g} | "
                     f"{e[0]:.5g} ± {e[1]:.3g} | {(e[0] - r[0]) / r[1]:+.3f} | "
                     f"{100 * (e[1] / r[1] - 1):+.1f} % |")
    tau = max(ref["tau"])
    lines += ["", f"Reference: MAP from {len(ref['map_log_joint_per_start'])} starts (log joints "
              f"within {np.ptp(ref['map_log_joint_per_start']):.1e} nats of each other); emcee, "
              f"{ref['n_walkers']} walkers x {ref['steps']} steps started within 1e-4 of the "
              f"MAP, {ref['discard']} steps discarded (10 τ), {ref['n_over_tau']:.0f} τ kept "
              f"(τ {min(ref['tau']):.0f}–{tau:.0f} steps), acceptance {ref['acceptance'][0]:.2f}"
              f"–{ref['acceptance'][2]:.2f}, lowest walker's median log density "
              f"{ref['worst_walker_gap']:.2f} nats below the median walker's. Importance "
              f"sampling: {imp['n']} draws from a Student-t (5 dof, 1.5 x the chain's "
              f"covariance), ESS {imp['ess']:.0f}.", ""]
    return lines


def write_table(results: dict[str, dict]) -> str:
    """Markdown of the cached results."""
    lines = [f"Measured {time.strftime('%Y-%m-%d')} on this machine (`uptime` load "
             f"{os.getloadavg()[0]:.2f}); simulated wall time: {MODEL_MIN:.0f}-minute model, "
             f"{WORKERS} workers.", ""]
    b = results.get("bridge")
    if b:
        lines += ["| study A, FE model, matern32, 39.8 m | model runs | sequential rounds | "
                  "simulated wall time | max mean dev. / ref. sd | max sd rel. dev. | "
                  "log evidence |", "|---|---|---|---|---|---|---|"]
        for key in ("emulator", "vbmc"):
            r, c = b[key], b[f"{key}_vs_ref"]
            lines.append(f"| {key} | {r['runs']} | {r['rounds']} | {r['sim_hours']:.1f} h | "
                         f"{c['max_mean_dev_sd']:.3f} | {c['max_sd_rel']:.3f} | "
                         f"{r['log_evidence']:.3f} ± {r['log_evidence_sd']:.3f} |")
        ref = b["reference"]
        lines += ["", f"Reference: emcee on the FE model, 32 walkers x {ref['steps']} steps "
                  f"(chain {ref['n_over_tau']:.0f} autocorrelation times). Means "
                  + ", ".join(f"{n} {m:.4g} ± {s:.3g}" for n, m, s in
                              zip(ref["names"], ref["mean"], ref["sd"])) + ".", ""]
    f = results.get("four")
    if f:
        lines += _four_table(f)
    s = results.get("studyb")
    if s and (b or "matern32" in s):
        lines += ["| study B kernel (emulator, shared store) | new runs | converged | "
                  "log evidence | log10 BF vs matern32 | VBMC's (docs/results.md) |",
                  "|---|---|---|---|---|---|"]
        if b and "matern32" not in s:
            s["matern32"] = b["emulator"]
        base = s["matern32"]["log_evidence"]
        for k in [k for k in torchshm.KERNELS if k in s]:
            r = s[k]
            bf = (r["log_evidence"] - base) / math.log(10)
            lines.append(f"| {k} | {r['new_runs']} | {r['converged']} | {r['log_evidence']:.3f} ± "
                         f"{r['log_evidence_sd']:.3f} | {bf:+.1f} | {VBMC_BF[k]:+.1f} |")
        lines += ["", f"Runs in the shared store after all five kernels: {s['store_runs']}.", ""]
    return "\n".join(lines)


def main() -> None:
    import logging

    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    logging.getLogger("torchshm.storage").setLevel(logging.WARNING)
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--part", nargs="+", default=["bridge", "four", "studyb"])
    parser.add_argument("--write", action="store_true", help="write docs/benchmarks.md")
    parser.add_argument("--kernels", nargs="+", default=list(STUDY_B), help="part studyb only")
    args = parser.parse_args()
    OUT.mkdir(parents=True, exist_ok=True)
    warnings.simplefilter("default")
    parts = {"reference": part_reference, "bridge": part_bridge, "four": part_four,
             "four_reference": part_four_reference, "studyb": part_studyb}
    for name in [n for n in args.part if n in parts]:  # e.g. --part table: only the table
        result = parts[name](tuple(args.kernels)) if name == "studyb" else parts[name]()
        (OUT / f"{name}.json").write_text(json.dumps(result, indent=1, default=float))
        print(name, json.dumps(result, indent=1, default=float), flush=True)
    results = {n: json.loads((OUT / f"{n}.json").read_text())
               for n in parts if (OUT / f"{n}.json").exists()}
    per_kernel = {k: json.loads((OUT / f"studyb_{k}.json").read_text())
                  for k in STUDY_B if (OUT / f"studyb_{k}.json").exists()}
    if per_kernel:
        results["studyb"] = {**results.get("studyb", {}), **per_kernel}
        results["studyb"]["store_runs"] = len(torchshm.EvaluationStore(
            OUT / "bridge_store.sqlite").all(torchshm.bridge705())[0])
    table = write_table(results)
    print(table)
    if args.write:
        doc = Path("docs/benchmarks.md")
        text = doc.read_text()
        block = f"<!-- bench_evaluations:start -->\n{table}\n<!-- bench_evaluations:end -->"
        pattern = re.compile(r"<!-- bench_evaluations:start -->.*<!-- bench_evaluations:end -->",
                             re.S)
        text = pattern.sub(lambda _: block, text) if pattern.search(text) else text + (
            "\n## Model runs: method=\"emulator\" against VBMC (`scripts/bench_evaluations.py`)"
            f"\n\n{block}\n")
        doc.write_text(text)


if __name__ == "__main__":
    main()

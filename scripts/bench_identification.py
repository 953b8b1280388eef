"""Every method on every case of the identification suite, in one run, into one table.

For each case of :mod:`benchmarks.cases` and each method of :mod:`benchmarks.methods`: model
runs, sequential rounds with 5 concurrent workers, the wall time those rounds take with a
10-minute model (plus the method's own compute), accuracy against the case's reference
(``benchmarks/references/<case>.json``, made by ``scripts/make_references.py``): the largest
|Δmean| in reference sds and the range of sd ratios over the identified parameters, Δlog Z,
the method's own CPU time (model time excluded), its convergence flag and any error. The table
replaces the section between the ``suite`` markers of docs/benchmarks.md.

GPry runs on the cases of ``--gpry-cases`` only (default: the 2- and 4-parameter ones, minutes of
its own CPU each). ``--jobs 2`` runs the (case, method) pairs two at a time in fresh processes.

Usage (from the repository root)::

    OMP_NUM_THREADS=1 python scripts/bench_identification.py --jobs 2 --out runs/suite.json
    python scripts/bench_identification.py --cases beam2_saturating --methods emulator --quick --no-docs
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import platform
import statistics
import sys
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import torch  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from benchmarks.cases import case_hash, make_problem  # noqa: E402
from benchmarks.catalog import CASES  # noqa: E402
from benchmarks.holdout import HELD_OUT, KNOWN  # noqa: E402
from benchmarks.methods import TimedModel, run_method  # noqa: E402

REFS = ROOT / "benchmarks" / "references"
DOC = ROOT / "docs" / "benchmarks.md"
BEGIN, END = "<!-- suite:begin -->", "<!-- suite:end -->"
#: each held-out set (``--holdout``, ``--fresh``, ``--third``, ``--edge``, ``--fifth``, ``--sixth``, ``--seventh``, ``--eighth``): its cases, and the markers and
#: title of its own section of docs/benchmarks.md
SETS = {
    "holdout": (HELD_OUT["holdout"], ("<!-- holdout:begin -->", "<!-- holdout:end -->"),
                "Held-out cases (`scripts/bench_identification.py --holdout`)"),
    "fresh": (HELD_OUT["fresh"], ("<!-- fresh:begin -->", "<!-- fresh:end -->"),
              "A second held-out set (`scripts/bench_identification.py --fresh`)"),
    "third": (HELD_OUT["third"], ("<!-- third:begin -->", "<!-- third:end -->"),
              "A third held-out set (`scripts/bench_identification.py --third`)"),
    "edge": (HELD_OUT["edge"], ("<!-- edge:begin -->", "<!-- edge:end -->"),
             "A fourth held-out set: 1, 7 and 8 parameters (`scripts/bench_identification.py --edge`)"),
    "fifth": (HELD_OUT["fifth"], ("<!-- fifth:begin -->", "<!-- fifth:end -->"),
              "A fifth held-out set: 2, 3, 4 and 6 parameters (`scripts/bench_identification.py --fifth`)"),
    "sixth": (HELD_OUT["sixth"], ("<!-- sixth:begin -->", "<!-- sixth:end -->"),
              "A sixth held-out set: 2, 3, 4 and 6 parameters (`scripts/bench_identification.py --sixth`)"),
    "seventh": (HELD_OUT["seventh"], ("<!-- seventh:begin -->", "<!-- seventh:end -->"),
                "A seventh held-out set: 2, 3, 4 and 6 parameters (`scripts/bench_identification.py --seventh`)"),
    "eighth": (HELD_OUT["eighth"], ("<!-- eighth:begin -->", "<!-- eighth:end -->"),
               "An eighth held-out set: 2, 3, 4 and 6 parameters (`scripts/bench_identification.py --eighth`)"),
}
METHODS = ("emulator", "vbmc", "gpry")
#: the cases GPry runs on by default: the 2- and 4-parameter ones (see docs/benchmarks.md)
GPRY_CASES = [name for name, case in CASES.items() if case.n_physical in (2, 4)]
MODEL_MINUTES = 10.0


#: the reference's moments are its importance sampling's from this effective sample size
MIN_ESS = 1000


def moments(ref: dict) -> tuple[np.ndarray, np.ndarray]:
    """The reference mean and sd `D`: importance sampling's (a Student-t mixture around the
    chains' modes, docs/benchmarks.md) where its ESS reaches :data:`MIN_ESS`, else the chains'.

    Importance sampling matched a 25^4-point quadrature of beam2_user_gamma's posterior to 1 %
    in sd; a chain's sd moves with a few walkers stranded in a tail (beam6_large_error's
    ``log10_k_D``: 0.159 against 0.123-0.125 from two importance samplings).
    """
    im = ref.get("importance", {})
    if im.get("ess", 0.0) >= MIN_ESS and "sd" in im:
        return np.asarray(im["mean"]), np.asarray(im["sd"])
    return np.asarray(ref["mean"]), np.asarray(ref["sd"])


def score(row: dict, ref: dict) -> dict:
    """Accuracy of a row against the reference: max |Δmean|/sd, sd ratio range, Δlog Z."""
    if "mean" not in row:
        return {}
    idx = [ref["names"].index(n) for n in ref["identified"]]
    mean, sd = np.asarray(row["mean"])[idx], np.asarray(row["sd"])[idx]
    rmean, rsd = (m[idx] for m in moments(ref))
    ratio = sd / rsd
    out = {"max_dmean_sd": float(np.max(np.abs(mean - rmean) / rsd)),
           "sd_ratio_min": float(ratio.min()), "sd_ratio_max": float(ratio.max())}
    if row.get("log_z") is not None:
        out["dlog_z"] = float(row["log_z"]) - ref["importance"]["log_evidence"]
    return out


def run_task(task: tuple[str, str, bool, int, dict]) -> dict:
    """One row: ``method`` on case ``name`` (``quick``, ``seed``, the emulator's ``options``),
    on one torch thread."""
    torch.set_num_threads(1)
    name, method, quick, seed, options = task
    case = KNOWN[name]
    path = REFS / f"{name}.json"
    ref = json.loads(path.read_text()) if path.exists() else None
    stale = ref is not None and ref["case_hash"] != case_hash(case)
    problem = make_problem(case, model=TimedModel(case.model()))
    t0 = time.perf_counter()
    row = run_method(problem, method, quick, seed, options if method == "emulator" else None)
    row["wall_s"] = time.perf_counter() - t0
    row["sim_wall_h"] = row["rounds"] * MODEL_MINUTES / 60 + row["own_cpu_s"] / 3600
    row.update(case=name, method=method, P=case.n_physical, D=len(problem.names), case_hash=case_hash(case),
               reference="stale" if stale else ("missing" if ref is None else "ok"))
    if ref is not None and not stale:
        row.update(score(row, ref))
    for key in ("mean", "sd"):
        if key in row:
            row[key] = np.asarray(row[key]).tolist()
    print(json.dumps({k: v for k, v in row.items() if k not in ("mean", "sd")}), flush=True)
    return row


def run_all(tasks: list[tuple[str, str, bool, int, dict]], jobs: int, save: Callable[[list[dict]], None]) -> list[dict]:
    """Rows of every task, ``jobs`` at a time, each in a fresh process (1 torch thread, so that
    CPU times stay comparable); ``save`` gets the rows after every task."""
    rows: list[dict] = []
    if jobs <= 1:
        for task in tasks:
            rows.append(run_task(task))
            save(rows)
        return rows
    pool = ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("spawn"), max_tasks_per_child=1)
    with pool:
        for future in as_completed([pool.submit(run_task, t) for t in tasks]):
            rows.append(future.result())
            save(rows)
    return rows


def _f(v: object, fmt: str) -> str:
    return "" if v is None else format(v, fmt)


def table(rows: list[dict], header: str, marks: tuple[str, str] = (BEGIN, END)) -> str:
    """The markdown section: per case x method rows, then per-method summaries."""
    lines = [marks[0], "", header, "",
             "| case | P | method | runs | rounds (5 workers) | wall, 10-min model [h] | max \\|Δmean\\|/sd "
             "| sd ratio | Δlog Z | own CPU [s] | converged | error |",
             "| --- | ---: | --- | ---: | ---: | ---: | ---: | --- | ---: | ---: | --- | --- |"]
    for r in rows:
        ratio = f"{r['sd_ratio_min']:.2f}–{r['sd_ratio_max']:.2f}" if "sd_ratio_min" in r else ""
        rounds, wall = ("–", "–") if r["error"] else (r["rounds"], f"{r['sim_wall_h']:.1f}")  # unknown batches
        lines.append(f"| {r['case']} | {r['P']} | {r['method']} | {r['runs']} | {rounds} | "
                     f"{wall} | {_f(r.get('max_dmean_sd'), '.2f')} | {ratio} | "
                     f"{_f(r.get('dlog_z'), '+.2f')} | {r['own_cpu_s']:.1f} | {'yes' if r['converged'] else 'no'} | "
                     f"{r['error'].replace('|', '/')}{' (ran on an earlier definition of the case)' if r.get('reference') == 'old definition' else ''} |")
    lines += ["", "| method | cases (errors) | median max \\|Δmean\\|/sd | worst (case) | median \\|Δlog Z\\| | "
              "worst \\|Δlog Z\\| | median runs | median own CPU [s] |", "| --- | --- | ---: | --- | ---: | ---: | ---: | ---: |"]
    for m in dict.fromkeys(r["method"] for r in rows):
        mine = [r for r in rows if r["method"] == m]
        acc = [r for r in mine if "max_dmean_sd" in r]
        dz = [abs(r["dlog_z"]) for r in mine if "dlog_z" in r]
        worst = max(acc, key=lambda r: r["max_dmean_sd"]) if acc else None
        worst_text = "" if worst is None else f"{worst['max_dmean_sd']:.2f} ({worst['case']})"
        lines.append(f"| {m} | {len(mine)} ({sum(bool(r['error']) for r in mine)}) | "
                     f"{_f(statistics.median([r['max_dmean_sd'] for r in acc]) if acc else None, '.2f')} | "
                     f"{worst_text} | "
                     f"{_f(statistics.median(dz) if dz else None, '.2f')} | {_f(max(dz) if dz else None, '.2f')} | "
                     f"{statistics.median(r['runs'] for r in mine):.0f} | "
                     f"{statistics.median(r['own_cpu_s'] for r in mine):.1f} |")
    emu = [r for r in rows if r["method"] == "emulator" and not r["error"]]
    groups = {p: [r["runs"] for r in emu if r["P"] == p] for p in sorted({r["P"] for r in emu})}
    if groups:
        lines += ["", "Emulator, median model runs per number of physical parameters: " + ", ".join(
            f"P = {p}: {statistics.median(v):.0f} ({len(v)} cases)" for p, v in groups.items()) + "."]
    with_gpry = {r["case"] for r in rows if r["method"] == "gpry"}
    without = [c for c in dict.fromkeys(r["case"] for r in rows) if c not in with_gpry]
    if with_gpry and without:
        lines += ["", f"No GPry row for {', '.join(without)}: GPry runs on the cases of `--gpry-cases` only "
                  "(default: the 2- and 4-parameter ones), its own compute being minutes per case."]
    lines += ["", marks[1]]
    return "\n".join(lines)


def write_doc(section: str, marks: tuple[str, str] = (BEGIN, END),
              title: str = "Identification suite (`scripts/bench_identification.py`)") -> None:
    """Replace the marked section of docs/benchmarks.md (append it under ``title`` the first time)."""
    text = DOC.read_text()
    if marks[0] in text and marks[1] in text:
        text = text[: text.index(marks[0])] + section + text[text.index(marks[1]) + len(marks[1]):]
    else:
        text = text.rstrip("\n") + f"\n\n## {title}\n\n" + section + "\n"
    DOC.write_text(text)


def rescore(files: list[Path]) -> tuple[list[dict], list]:
    """Rows of earlier ``--out`` files scored against the current references, and their meta."""
    saved = [json.loads(f.read_text()) for f in files]
    rows = [r for s in saved for r in s["rows"]]
    for row in rows:
        path = REFS / f"{row['case']}.json"
        now = case_hash(KNOWN[row["case"]])
        if row.get("case_hash", now) != now or row.get("reference") == "old definition":
            row["reference"] = "old definition"  # the row ran on an earlier definition of the case
            for key in ("max_dmean_sd", "sd_ratio_min", "sd_ratio_max", "dlog_z"):
                row.pop(key, None)
        elif path.exists() and json.loads(path.read_text())["case_hash"] == now:
            row.update(score(row, json.loads(path.read_text())), reference="ok")
    meta = [min(s["meta"][0] for s in saved), saved[0]["meta"][1], saved[-1]["meta"][2]]
    commands = [s["meta"][3] for s in saved if len(s["meta"]) > 3]
    return rows, meta + ([commands] if commands else [])


def header(meta: list, n_files: int) -> str:
    """The table's first paragraph: how it was made (command, start, load) and what its columns are."""
    start, load0, load1 = meta[:3]
    commands = meta[3] if len(meta) > 3 else []
    commands = [commands] if isinstance(commands, str) else commands
    if n_files > 1:
        how = f"{n_files} runs ({'; '.join(f'`{c}`' for c in commands) or 'one per `--methods`'}) merged by `--rescore`,"
    else:
        how = f"Run of `{commands[0] if commands else 'python scripts/bench_identification.py'}`"
    return (f"{how} started {start}, {platform.machine()}, torch {torch.__version__}, 1 torch thread per "
            f"process; load average (1, 5, 15 min) {', '.join(f'{v:.1f}' for v in load0)} at the start, "
            f"{', '.join(f'{v:.1f}' for v in load1)} at the end (2 shared cores: CPU times are the comparable "
            f"figures). Runs: distinct model runs; rounds: sequential rounds with 5 concurrent runs; wall: "
            f"rounds x 10 min + own CPU; accuracy over the parameters the reference identifies; Δlog Z: the "
            f"method's log evidence (ELBO for VBMC) minus the reference's.")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="+", default=list(CASES), choices=list(KNOWN))
    parser.add_argument("--holdout", action="store_true", help="the held-out cases (benchmarks/holdout.py) "
                        "instead of the suite's; their table goes to its own section of docs/benchmarks.md")
    parser.add_argument("--fresh", action="store_true", help="the second held-out set (benchmarks/holdout.py "
                        "FRESH), drawn after the methods' defaults were fixed; its own section of docs/benchmarks.md")
    parser.add_argument("--third", action="store_true", help="the third held-out set (benchmarks/holdout.py "
                        "THIRD: damage, 5 parameters); its own section of docs/benchmarks.md")
    parser.add_argument("--edge", action="store_true", help="the fourth held-out set (benchmarks/holdout.py "
                        "EDGE: 1, 7 and 8 physical parameters); its own section of docs/benchmarks.md")
    parser.add_argument("--fifth", action="store_true", help="the fifth held-out set (benchmarks/holdout.py "
                        "FIFTH: 2, 3, 4 and 6 physical parameters); its own section of docs/benchmarks.md")
    parser.add_argument("--sixth", action="store_true", help="the sixth held-out set (benchmarks/holdout.py "
                        "SIXTH: 2, 3, 4 and 6 physical parameters); its own section of docs/benchmarks.md")
    parser.add_argument("--seventh", action="store_true", help="the seventh held-out set (benchmarks/holdout.py "
                        "SEVENTH: 2, 3, 4 and 6 physical parameters); its own section of docs/benchmarks.md")
    parser.add_argument("--eighth", action="store_true", help="the eighth held-out set (benchmarks/holdout.py "
                        "EIGHTH: 2, 3, 4 and 6 physical parameters); its own section of docs/benchmarks.md")
    parser.add_argument("--methods", nargs="+", default=list(METHODS), choices=[*METHODS, "emcee"])
    parser.add_argument("--gpry-cases", nargs="+", default=GPRY_CASES, choices=list(KNOWN),
                        help="the cases GPry runs on (default: the 2- and 4-parameter ones; minutes of CPU each)")
    parser.add_argument("--jobs", type=int, default=1, help="(case, method) runs at a time, in separate processes")
    parser.add_argument("--quick", action="store_true", help="tiny budgets (a smoke run, not a benchmark)")
    parser.add_argument("--out", type=Path, help="JSON file of all rows, rewritten after every run")
    parser.add_argument("--no-docs", action="store_true", help="do not write docs/benchmarks.md")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--emulator-options", type=json.loads, default={}, metavar="JSON",
                        help='keyword options of method="emulator", e.g. \'{"tv_tol": 0.1}\' (default: none)')
    parser.add_argument("--rescore", type=Path, nargs="+", help="score the rows of earlier --out files "
                        "again (e.g. after making references; several: runs split by --methods) instead of running")
    args = parser.parse_args()
    for name, (cases, _, _) in SETS.items():
        if getattr(args, name):
            args.cases = [c for c in args.cases if c in cases] or list(cases)
    if os.environ.get("TORCHSHM_SMOKE") == "1":  # a check that it runs (docs test), no figures
        args.cases, args.methods, args.quick, args.no_docs = args.cases[:1], args.methods[:1], True, True
        print(f"TORCHSHM_SMOKE=1: --quick, {args.cases} with {args.methods} only, docs/benchmarks.md left as it is")
    torch.set_num_threads(1)
    if args.rescore:
        rows, meta = rescore(args.rescore)
    else:
        command = " ".join(["python scripts/bench_identification.py", *sys.argv[1:]])
        start, load0 = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), os.getloadavg()
        if args.out:
            args.out.parent.mkdir(parents=True, exist_ok=True)  # e.g. runs/ on a fresh checkout
        tasks = sorted(((c, m, args.quick, args.seed, args.emulator_options) for m in args.methods for c in args.cases
                        if m != "gpry" or c in args.gpry_cases), key=lambda t: t[1] != "gpry")  # longest first

        def save(done: list[dict]) -> None:
            if args.out:  # after every run, so that a long run can be scored while it goes on
                args.out.write_text(json.dumps({"meta": [start, load0, os.getloadavg(), command], "rows": done}) + "\n")

        rows = run_all(tasks, args.jobs, save)
        meta = [start, load0, os.getloadavg(), command]
        save(rows)
    order = {c: i for i, c in enumerate(KNOWN)}
    rows.sort(key=lambda r: (order[r["case"]], [*METHODS, "emcee"].index(r["method"])))
    held_out = next((v for v in SETS.values() if all(r["case"] in v[0] for r in rows)), None)
    marks, title = (held_out[1], held_out[2]) if held_out else ((BEGIN, END), "Identification suite "
                                                                 "(`scripts/bench_identification.py`)")
    section = table(rows, header(meta, len(args.rescore or [None])), marks)
    print(section)
    if not args.no_docs:
        write_doc(section, marks, title)

if __name__ == "__main__":
    main()

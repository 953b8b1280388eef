"""Fault injection: kill identifications and a design fit sharing one store at random moments.

Usage::

    python scripts/fault_injection.py                      # 20 kills; VBMC, emcee, design fit
    python scripts/fault_injection.py --kills 2 --jobs emcee,fit --small   # CI-sized
    python scripts/fault_injection.py --load 2             # with 2 CPU-burning processes
    python scripts/fault_injection.py --jobs vbmc,vbmc1,emcee,fit    # 4 processes, one store

Each job of ``--jobs`` (see ``scripts/fault_jobs.py``: ``vbmc``, ``vbmc1``, ``emcee``, ``fit``,
``emulator``) is first run uninterrupted on a store of its own (the reference). Then all jobs
are started at once as separate processes on ONE store; at each of ``--kills`` random moments
(uniform in ``[0, 2 T / kills]`` seconds after the restarted processes are ready, ``T`` the
longest reference run) every running job is killed with SIGKILL and the store is checked; the
killed jobs are restarted, until the kills are spent and every job finishes. Reported:

* kills, and model calls in flight at a kill (started by a killed process, never stored);
* runs repeated beyond in flight: model calls that began while the store already held that
  θp (observed by the model itself; must be 0);
* runs duplicated beyond in flight: calls of a θp beyond its first that no kill explains
  (two live processes running the same θp at once; must be 0: the store's claims prevent it);
* integrity failures over every check (:func:`torchshm.storage.integrity.check_store`: SQLite
  ``integrity_check``, each row's checksum, the spool; must be 0);
* the final posterior vs the uninterrupted one: the largest difference of a mean, in
  posterior standard deviations, and of a standard deviation, relative; for emcee also the
  largest difference of any sample (the resumed chain is the same chain); for the fit the
  largest prediction difference. VBMC restarted from stored points is a different run, so its
  difference is shown beside that between two uninterrupted runs with other seeds
  (``vbmc1``, run as a reference) and beside the exact posterior of the linear-Gaussian problem.

Exit status 1 if a run was repeated, an integrity check failed or a job failed.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from fault_jobs import exact_posterior  # noqa: E402

from torchshm.storage.integrity import check_store  # noqa: E402

#: job size passed to ``fault_jobs.py`` (``--small``: a CI-sized chain and design)
SIZE = ""


def _start(job: str, store: Path, log: Path, result: Path, delay: float) -> tuple[subprocess.Popen, Path]:
    ready = result.with_name(f"{result.name}.ready.{time.monotonic_ns()}")
    env = dict(os.environ, OMP_NUM_THREADS="1", FAULT_DELAY=str(delay), PYTHONWARNINGS="ignore",
               FAULT_SIZE=SIZE)
    command = [sys.executable, str(HERE / "fault_jobs.py"), job, str(store), str(log), str(result),
               str(ready)]
    errors = open(result.with_name(f"{result.name}.stderr"), "ab")
    return subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL, stderr=errors), ready


def references(jobs: list[str], folder: Path, delay: float) -> tuple[dict[str, dict], float]:
    """Run every job uninterrupted on its own store (all at once); results and longest time.

    Jobs whose result is already in ``folder`` (from an earlier call) are not run again.
    """
    folder.mkdir(parents=True, exist_ok=True)
    times = folder / "seconds.json"
    seconds = json.loads(times.read_text()) if times.exists() else {}
    t0, running = time.monotonic(), {}
    for job in jobs:
        if job not in seconds or not (folder / f"{job}.json").exists():
            running[job] = _start(job, folder / f"{job}.sqlite", folder / f"{job}.calls",
                                  folder / f"{job}.json", delay)[0]
    for job, process in running.items():
        if process.wait() != 0:
            raise RuntimeError(f"reference job {job} failed; see {folder / job}.json.stderr")
        seconds[job] = time.monotonic() - t0
    times.write_text(json.dumps(seconds))
    return {job: _result(folder / f"{job}.json") for job in jobs}, max(seconds[j] for j in jobs)


def _result(path: Path) -> dict:
    out = json.loads(path.read_text())
    samples = Path(f"{path}.samples.npy")
    if samples.exists():
        out["samples"] = np.load(samples)
    return out


def faulted(jobs: list[str], folder: Path, kills: int, horizon: float, delay: float,
            rng: np.random.Generator, timeout: float) -> dict:
    """Run the jobs on one store, killing every running one at ``kills`` random moments."""
    folder.mkdir(parents=True, exist_ok=True)
    store, log = folder / "store.sqlite", folder / "calls.log"
    procs: dict[str, tuple[subprocess.Popen, Path]] = {}
    done: set[str] = set()
    events: list[dict] = []
    integrity = []
    deadline = time.monotonic() + timeout
    while len(done) < len(jobs):
        if time.monotonic() > deadline:
            raise RuntimeError(f"faulted run did not finish in {timeout:.0f} s")
        for job in jobs:
            if job not in done and job not in procs:
                procs[job] = _start(job, store, log, folder / f"{job}.json", delay)
        for job, (process, _) in list(procs.items()):
            if process.poll() is not None:
                if process.returncode != 0:
                    raise RuntimeError(f"job {job} failed (status {process.returncode}); "
                                       f"see {folder / job}.json.stderr")
                done.add(job)
                del procs[job]
        if len(events) >= kills or not procs:
            time.sleep(0.05)
            continue
        while any(not ready.exists() and p.poll() is None for p, ready in procs.values()):
            time.sleep(0.01)
        moment = time.monotonic() + rng.uniform(0.0, horizon)
        while time.monotonic() < moment and all(p.poll() is None for p, _ in procs.values()):
            time.sleep(0.01)
        victims = {job: p for job, (p, _) in procs.items() if p.poll() is None}
        if not victims:
            continue
        for process in victims.values():
            process.send_signal(signal.SIGKILL)
        for job, process in victims.items():
            process.wait()
            if process.returncode == -signal.SIGKILL:
                del procs[job]
        report = check_store(store)
        integrity.append(report.failures)
        events.append({"jobs": sorted(victims), "pids": [p.pid for p in victims.values()]})
    final = check_store(store)
    integrity.append(final.failures)
    return {"events": events, "integrity": integrity, "final": final.summary(),
            "results": {job: _result(folder / f"{job}.json") for job in jobs},
            "calls": _calls(log, store, events)}


def _calls(log: Path, store: Path, events: list[dict]) -> dict[str, int]:
    """Model-call accounting from the call log and the store's rows."""
    import sqlite3

    starts: dict[str, list[int]] = {}
    repeated = 0
    for line in log.read_text().splitlines():
        parts = line.split()
        if len(parts) >= 5 and parts[0] == "start":
            starts.setdefault(parts[1], []).append(int(parts[2]))
            repeated += parts[3] == "1"
    with sqlite3.connect(store) as con:
        stored = {(key, pid) for key, pid in con.execute("SELECT theta_key, pid FROM evaluations")}
    killed = {pid for event in events for pid in event["pids"]}
    lost = {key: sum(1 for pid in pids if pid in killed and (key, pid) not in stored)
            for key, pids in starts.items()}
    n_calls = sum(len(pids) for pids in starts.values())
    duplicated = sum(max(0, len(pids) - 1 - lost[key]) for key, pids in starts.items())
    return {"calls": n_calls, "distinct": len(starts), "extra_calls": n_calls - len(starts),
            "in_flight_at_kills": sum(lost.values()), "repeated_beyond_in_flight": repeated,
            "duplicated_beyond_in_flight": duplicated}


def compare(job: str, got: dict, ref: dict, exact: tuple[np.ndarray, np.ndarray]) -> dict:
    """Differences of the faulted job's final result from the uninterrupted one's."""
    if job == "fit":
        a, b = np.asarray(got["prediction"]), np.asarray(ref["prediction"])
        return {"max_prediction_diff": float(np.max(np.abs(a - b))),
                "relative": float(np.max(np.abs(a - b)) / np.max(np.abs(b)))}
    sd = np.asarray(ref["sd"])
    out = {
        "mean_diff_sd": float(np.max(np.abs(np.subtract(got["mean"], ref["mean"])) / sd)),
        "sd_diff_rel": float(np.max(np.abs(np.subtract(got["sd"], sd)) / sd)),
        "exact_mean_diff_sd": float(np.max(np.abs(np.subtract(got["mean"], exact[0])) / exact[1])),
        "n_model_evaluations_last_run": int(got["n_model_evaluations"]),
    }
    if job == "emcee":
        a, b = got["samples"], ref["samples"]
        out["max_sample_diff"] = float(np.max(np.abs(a - b))) if a.shape == b.shape else float("inf")
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kills", type=int, default=20, help="SIGKILL moments (default 20)")
    parser.add_argument("--jobs", default="vbmc,emcee,fit",
                        help="comma-separated jobs sharing the store (default vbmc,emcee,fit)")
    parser.add_argument("--load", type=int, default=0, help="CPU-burning processes alongside")
    parser.add_argument("--delay", type=float, default=0.02, help="seconds per model call")
    parser.add_argument("--seed", type=int, default=0, help="seed of the kill moments")
    parser.add_argument("--folder", type=Path, default=None, help="working folder (default: temporary)")
    parser.add_argument("--timeout", type=float, default=3600.0, help="limit of the faulted run [s]")
    parser.add_argument("--json", type=Path, default=None, help="write the report here too")
    parser.add_argument("--small", action="store_true", help="CI-sized jobs (short chain, 3x3 design)")
    parser.add_argument("--reference", type=Path, default=None,
                        help="folder of uninterrupted runs to reuse (default: <folder>/reference)")
    args = parser.parse_args(argv)
    global SIZE
    SIZE = "small" if args.small else ""
    jobs = [j for j in args.jobs.split(",") if j]
    if "emulator" in jobs:
        from torchshm.inference.identify import METHODS

        if "emulator" not in METHODS:
            print("fault_injection: the emulator method is not available; left out", file=sys.stderr)
            jobs.remove("emulator")
    folder = args.folder or Path(tempfile.mkdtemp(prefix="fault-injection-"))
    burners = [subprocess.Popen([sys.executable, "-c", "while True: pass"])
               for _ in range(args.load)]
    try:
        t0 = time.monotonic()
        spread = ["vbmc1"] if "vbmc" in jobs and "vbmc1" not in jobs else []
        ref, longest = references(jobs + spread, args.reference or folder / "reference",
                                  args.delay)
        horizon = 2.0 * longest / max(1, args.kills)
        out = faulted(jobs, folder / "faulted", args.kills, horizon, args.delay,
                      np.random.default_rng(args.seed), args.timeout)
    finally:
        for burner in burners:
            burner.kill()
            burner.wait()
    exact = exact_posterior()
    report = {
        "jobs": jobs, "load_processes": args.load, "kills": len(out["events"]),
        "processes_killed": sum(len(e["jobs"]) for e in out["events"]),
        **out["calls"], "integrity_checks": len(out["integrity"]),
        "integrity_failures": int(sum(out["integrity"])), "final_store": out["final"],
        "reference_seconds": round(longest, 1), "total_seconds": round(time.monotonic() - t0, 1),
        "posterior": {job: compare(job, out["results"][job], ref[job], exact) for job in jobs},
    }
    if "vbmc" in jobs:
        report["posterior"]["vbmc_seed0_vs_seed1"] = compare("vbmc", ref["vbmc1"], ref["vbmc"], exact)
    text = json.dumps(report, indent=1)
    print(text)
    if args.json is not None:
        args.json.write_text(text)
    failed = (report["repeated_beyond_in_flight"] or report["duplicated_beyond_in_flight"]
              or report["integrity_failures"])
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Disk left by the CalculiX example's run folders: 240 runs with the default keep="failed"
against keep="all".

    python scripts/bench_run_folders.py [--runs 240] [--keep failed all] [--n-jobs 1]

Each configuration runs the example's model (examples/calculix_slab, needs ``ccx``) at
``--runs`` θp drawn uniformly in the prior box, through an evaluation store, into a fresh work
folder, then reports the bytes left under it (run folders and index.csv) and the CPU time.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from examples.calculix_slab.slab import calculix_slab  # noqa: E402
from torchshm.storage import EvaluationStore, evaluate  # noqa: E402


def measure(runs: int, keep: str, n_jobs: int, seed: int = 0) -> dict[str, float]:
    """Run the slab ``runs`` times with ``keep``; bytes left, folders kept and times."""
    rng = np.random.default_rng(seed)
    design = np.column_stack([rng.uniform(20.0, 50.0, runs), rng.uniform(5.0, 8.0, runs)])
    with tempfile.TemporaryDirectory() as scratch:
        model = calculix_slab(workdir=Path(scratch) / "fe", keep=keep)
        wall, cpu = time.perf_counter(), time.process_time()
        result = evaluate(model, design, store=EvaluationStore(Path(scratch) / "store.sqlite"), n_jobs=n_jobs)
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        return {"runs": runs, "ok": int(result.ok.sum()), "bytes": model.disk_used,
                "folders": len(list(model.workdir.glob("run-*"))), "wall_s": wall, "cpu_s": cpu,
                "summary": model.runs_summary()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=240)
    parser.add_argument("--keep", nargs="+", default=["failed", "all"])
    parser.add_argument("--n-jobs", type=int, default=1)
    args = parser.parse_args()
    for keep in args.keep:
        row = measure(args.runs, keep, args.n_jobs)
        print(f"keep={keep!r}: {row['runs']} runs ({row['ok']} ok), {row['folders']} folders left, "
              f"{row['bytes'] / 1e6:.2f} MB ({row['bytes']} bytes); wall {row['wall_s']:.0f} s, "
              f"main-process CPU {row['cpu_s']:.0f} s", flush=True)


if __name__ == "__main__":
    main()

"""Peak memory and CPU time of the held-out predictive on the camera example's field.

    OMP_NUM_THREADS=1 python scripts/bench_predictive_memory.py [--n 100,500,2000]
        [--code OTHER_CHECKOUT] [--keep draws,summary]

The problem is the one ``examples/plate_dic_camera/README.md``'s command builds (155,792 points
per image, kernel ``upscaled``, load cases 0.5 and 1.5 m), with 99 stored model runs near the
posterior (the README run's count) and a posterior of draws near its mean: no identification.
Each measurement runs in its own process, which imports ``torchshm`` from this checkout or from
``--code`` (e.g. the main checkout, to compare side by side), and reports for
``posterior_predictive(post, [1.0], n)`` the growth of the peak resident memory (VmHWM, reset
just before the call) and the CPU time of the call, with the load average; with this
checkout's code also the estimate of ``predictive_memory``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OVERRIDES = [f"hydra.searchpath=[file://{ROOT / 'examples/plate_dic_camera/conf'}]", "model=plate_dic_camera",
             "priors=plate_dic_camera", "+data=plate_dic_camera", "method=vbmc", "kernel=upscaled",
             "predict.loads=[1.0]", "likelihood.sigma_m=0"]
#: posterior mean and sd of the README's run (E [GPa], log10_k, sigma_a [µε])
MEAN, SD = [3.1961, 5.4967, 681.6], [0.0114, 0.0103, 2.6]


def _status(key: str) -> int:
    """``VmRSS`` or ``VmHWM`` of this process [bytes]."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(key + ":"):
            return int(line.split()[1]) * 1024
    raise KeyError(key)


def measure(n: int, keep: str) -> dict[str, object]:
    """One predictive in this process (module docstring)."""
    import numpy as np
    from hydra import compose, initialize_config_dir

    import torchshm
    from torchshm.cli.job import build_problem, load_data
    from torchshm.config import CONF_DIR, CONFIG_NAME, register_configs, to_settings
    from torchshm.inference import Posterior

    os.chdir(ROOT)
    sys.path.append(str(ROOT))  # the example's model; torchshm is already imported
    register_configs()
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        settings = to_settings(compose(CONFIG_NAME, overrides=OVERRIDES))
    from torchshm.cli.models import instantiate_model

    model = instantiate_model(settings.model, ROOT)
    problem = build_problem(settings, model, load_data(settings.data, ROOT), ROOT)
    rng = np.random.default_rng(0)
    mean, sd = np.array(MEAN), np.array(SD)
    problem.model_outputs(problem.split.physical(mean + 3.0 * sd * rng.standard_normal((99, 3))))
    post = Posterior(names=list(problem.names), method="vbmc", samples=mean + sd * rng.standard_normal((4000, 3)),
                     n_chains=1, priors=dict(problem.priors), problem=problem)
    kw = {} if keep == "old" else {"keep": keep}
    estimate = None if keep == "old" else torchshm.predictive_memory(problem, [1.0], n, keep=keep)
    rss = _status("VmRSS")
    Path("/proc/self/clear_refs").write_text("5")  # VmHWM := VmRSS
    cpu, wall = time.process_time(), time.perf_counter()
    pred = torchshm.posterior_predictive(post, [1.0], n=n, seed=0, **kw)
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    return {"n": n, "keep": keep, "points": int(pred.x.shape[0]), "peak_growth_gib": (_status("VmHWM") - rss) / 2**30,
            "estimate_gib": None if estimate is None else estimate / 2**30, "cpu_s": cpu, "wall_s": wall,
            "mean_sum": float(pred.mean.sum()), "load": os.getloadavg()[0]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", default="100,500,2000")
    parser.add_argument("--keep", default="draws,summary", help="this checkout's keep= values")
    parser.add_argument("--code", default=None, help="another checkout to measure beside this one")
    parser.add_argument("--code-n", default="100,500", help="draws measured with --code")
    parser.add_argument("--one", nargs=2, metavar=("N", "KEEP"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        print(json.dumps(measure(int(args.one[0]), args.one[1])))
        return
    runs = [(str(ROOT), n, k) for n in args.n.split(",") for k in args.keep.split(",")]
    if args.code:
        runs = [(args.code, n, "old") for n in args.code_n.split(",")] + runs
    print(f"load average at start {os.getloadavg()}")
    for code, n, keep in runs:
        env = {**os.environ, "PYTHONPATH": code, "OMP_NUM_THREADS": os.environ.get("OMP_NUM_THREADS", "1")}
        done = subprocess.run([sys.executable, __file__, "--one", n, keep], env=env, capture_output=True, text=True)
        line = done.stdout.strip().splitlines()[-1] if done.returncode == 0 else done.stderr.strip()[-300:]
        print(f"{code}: {line}", flush=True)


if __name__ == "__main__":
    main()

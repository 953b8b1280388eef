"""The field emulator's kernel: one ARD kernel of all inputs against that kernel plus one per input.

The field emulator of ``method="emulator"`` (:mod:`torchshm.inference.adaptive.field`) is one
GPyTorch GP whose outputs share one kernel; by default a Matérn 5/2 ARD kernel of all the
physical parameters. Far from its runs such a kernel reverts to the runs' mean, where the
exploration of the box needs it most. Structural responses are often close to a sum of the
parameters' effects (two cracks far apart, two supports' stiffnesses), which a product kernel
cannot carry to a combination of inputs no run has; the kernel ``matern52_additive`` adds one
Matérn kernel per input (:data:`torchshm.surrogate.gp.SURROGATE_KERNELS`), the weights of the
terms fitted by the marginal likelihood like the rest.

On the designs and test points of ``scripts/bench_emulator_error.py`` (a Latin hypercube of the
plausible box, then draws of the reference posterior; "far": uniform in the plausible box,
"near": within 2 reference sd), both emulators fitted to the same runs, the script gives:

- the error of the emulated log-likelihood ``|ℓ(true strains) - ℓ(emulator mean)|`` [nat]
  (Eq. 21, the same covariance both times);
- the rms of that error over its modelled sd (``EmulatedLogJoint.error_variance``; 1 is
  calibrated) and the share of points beyond 3 of its sds;
- each fit's CPU time.

Usage::

    OMP_NUM_THREADS=1 .venv/bin/python scripts/bench_emulator_kernel.py [--cases NAME ...] [--points N]
"""

from __future__ import annotations

import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np
import torch

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))

from bench_emulator_error import _variances, emulators_at_designs, rows_of  # noqa: E402
from torchshm.inference.adaptive.field import FieldEmulator, model_transform  # noqa: E402
from torchshm.inference.adaptive.likelihood import EmulatedLogJoint  # noqa: E402

KERNELS = ("matern52", "matern52_additive")


def _refit(problem, emulator: FieldEmulator, kernel: str) -> tuple[FieldEmulator, float]:
    """``emulator``'s runs fitted again with ``kernel``, and the fit's CPU seconds."""
    start = time.process_time()
    sur = emulator.surrogate
    fitted = FieldEmulator.fit(emulator.theta_p.numpy(), sur.outputs.numpy(), sur.x, sur.loads,
                               model_transform(problem.model), kernel)
    return fitted, time.process_time() - start


def run_case(name: str, n_points: int, designs: tuple[tuple[int, int], ...], seed: int = 0) -> list[dict]:
    """Rows of both kernels' log-likelihood errors for one case: one per design and test set."""
    out, fits, fitted = [], {}, None
    for problem, emulator, _, runs, label, test, true in emulators_at_designs(name, n_points, designs, seed):
        if emulator is not fitted:  # one pair of fits per design, for both test sets
            fits, fitted = {kernel: _refit(problem, emulator, kernel) for kernel in KERNELS}, emulator
        row = {"case": name, "P": len(problem.physical_names), "runs": runs, "test": label}
        for kernel, (emu, cpu) in fits.items():
            log_joint = EmulatedLogJoint(problem, emu)
            variances, parts = _variances(log_joint, test)
            exact = log_joint.at(true, parts["var"], parts["theta"])
            delta = exact - log_joint.at(parts["mean"], parts["var"], parts["theta"])
            z = delta / np.sqrt(np.maximum(variances["correlated"], 1e-300))
            ok = np.isfinite(z)
            row[kernel] = {"median": float(np.median(np.abs(delta[ok]))), "p90": float(np.quantile(np.abs(delta[ok]), 0.9)),
                           "rms_z": float(np.sqrt(np.mean(z[ok] ** 2))), "over3": float(np.mean(np.abs(z[ok]) > 3)),
                           "fit_cpu_s": cpu}
        out.append(row)
        print(f"{name:18s} {runs:3d} runs {label:4s} " + " | ".join(
            f"{k}: median |Δ| {row[k]['median']:8.3g} 90 % {row[k]['p90']:8.3g} rms z {row[k]['rms_z']:6.2f} "
            f"fit {row[k]['fit_cpu_s']:5.1f} s" for k in KERNELS), flush=True)
    return out


def main() -> None:
    rows = rows_of(run_case, __doc__.splitlines()[0], 100)
    a, b = KERNELS
    print(f"\n| runs | test points | median over cases of the median \\|Δ\\| [nat], {a} / {b} | median ratio "
          f"{b} / {a} | cases 2× better / 2× worse | median rms z, {a} / {b} | worst rms z, {a} / {b} |")
    print("| ---: | --- | ---: | ---: | ---: | ---: | ---: |")
    for runs in sorted({r["runs"] for r in rows}):
        for label in ("far", "near"):
            sel = [r for r in rows if r["runs"] == runs and r["test"] == label]
            if not sel:
                continue
            ratio = [r[b]["median"] / max(r[a]["median"], 1e-300) for r in sel]
            print(f"| {runs} | {label} | {statistics.median(r[a]['median'] for r in sel):.3g} / "
                  f"{statistics.median(r[b]['median'] for r in sel):.3g} | {statistics.median(ratio):.2f} | "
                  f"{sum(q < 0.5 for q in ratio)} / {sum(q > 2 for q in ratio)} of {len(sel)} | "
                  f"{statistics.median(r[a]['rms_z'] for r in sel):.2f} / {statistics.median(r[b]['rms_z'] for r in sel):.2f} | "
                  f"{max(r[a]['rms_z'] for r in sel):.2f} / {max(r[b]['rms_z'] for r in sel):.2f} |")
    fit = {k: statistics.median(r[k]["fit_cpu_s"] for r in rows) for k in KERNELS}
    print("median fit CPU s: " + ", ".join(f"{k} {v:.2f}" for k, v in fit.items()))
    print("load average at the end " + ", ".join(f"{x:.1f}" for x in os.getloadavg()))


if __name__ == "__main__":
    main()

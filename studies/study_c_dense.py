"""Study C below 0.1 m: the synthetic campaign read at 0.05, 0.01 and 0.005 m (and 0.00065 m).

    python studies/study_c_dense.py [--pitches 0.1 0.05 0.01 0.005] [--out studies/out/c_dense]
                                    [--max-fun-evals 150] [--n-predict 1000]

For each pitch: the finite element model ``torchshm.bridge705(pitch=...)`` and the campaign
``torchshm.synthetic_campaign(seed=0, pitch=...)``, Matérn 3/2, VBMC on the eleven load cases
other than 70.4 m (as sub-case C1), prediction of 70.4 m. From 1,000 points per load case the
likelihood is the exact O(n) state-space form (``docs/likelihood.md``). Writes ``table.md``
(posterior, KL, 95 % interval widths, R² and coverage at the 0.1 m positions and at every
position, wall times) and ``fig.png`` (posterior intervals against the pitch) into ``--out``.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np
import torch

import torchshm
from torchshm.predictive import prediction_view
from torchshm.predictive.memory import check_memory

INFER = [10.5, 16.9, 24.5, 32.2, 39.8, 47.5, 55.1, 62.8, 78.1, 85.7, 99.9]
PREDICT = [70.4]


def run_pitch(pitch: float, args: argparse.Namespace) -> dict[str, object]:
    """Identify and predict at one pitch; the row of the table."""
    t0 = time.perf_counter()
    model = torchshm.bridge705(pitch=pitch)
    data = torchshm.synthetic_campaign(seed=0, pitch=pitch)
    problem = torchshm.Problem(model, data.select(INFER), kernel="matern32")
    check_memory(prediction_view(problem), len(PREDICT), args.n_predict, "summary", problem.kernel,
                 what=("--n-predict", "PREDICT"))  # before the identification, not after it
    t1 = time.perf_counter()
    post = torchshm.identify(problem, method="vbmc", seed=0, max_fun_evals=args.max_fun_evals)
    t2 = time.perf_counter()
    pred = torchshm.posterior_predictive(post, PREDICT, n=args.n_predict, keep="summary")
    t3 = time.perf_counter()
    observed = torch.as_tensor(data.select(PREDICT).y)
    coarse = torch.as_tensor(np.isclose((data.x - 35.0) / 0.1, np.round((data.x - 35.0) / 0.1), atol=1e-6))
    row: dict[str, object] = {
        "pitch": pitch,
        "n": int(data.x.size),
        "summary": post.summary(),
        "evaluations": post.n_model_evaluations,
        "kl": float(torchshm.kl_divergence(post, n=10_000)),
        "setup_s": t1 - t0,
        "identify_s": t2 - t1,
        "predict_s": t3 - t2,
    }
    for label, mask in (("all", torch.ones_like(coarse)), ("0.1", coarse)):
        y, mean = observed[:, mask], pred.mean[:, mask]
        lower, upper = pred.lower[:, mask], pred.upper[:, mask]
        resid = float((y - mean).square().sum())
        row[f"r2_{label}"] = 1.0 - resid / float((y - y.mean()).square().sum())
        row[f"width_{label}"] = float((upper - lower).mean())
        row[f"coverage_{label}"] = float(((y >= lower) & (y <= upper)).double().mean())
    return row


def table(rows: list[dict[str, object]]) -> str:
    """Markdown table of the rows."""
    names = ["E_c", "log10_K_r", "sigma_a", "length"]
    lines = [
        "| pitch [m] | n per load | " + " | ".join(names) + " | KL [nats] | evals | R² (0.1 m / all) "
        "| width [µε] (0.1 m / all) | coverage (0.1 m / all) | identify [s] | predict [s] |",
        "| ---: | ---: | " + " | ".join("---" for _ in names) + " | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for r in rows:
        s = r["summary"]
        cells = [f"{s[k].mean:.3g} [{s[k].q2_5:.3g}, {s[k].q97_5:.3g}]" for k in names]
        lines.append(
            f"| {r['pitch']} | {r['n']:,} | " + " | ".join(cells) + f" | {r['kl']:.2f} | {r['evaluations']} "
            f"| {r['r2_0.1']:.3f} / {r['r2_all']:.3f} | {r['width_0.1']:.2f} / {r['width_all']:.2f} "
            f"| {100 * r['coverage_0.1']:.1f} % / {100 * r['coverage_all']:.1f} % "
            f"| {r['identify_s']:.0f} | {r['predict_s']:.1f} |"
        )
    return "\n".join(lines) + "\n"


def figure(rows: list[dict[str, object]], path: Path) -> None:
    """Posterior mean and 95 % interval of each parameter against the pitch."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = ["E_c", "log10_K_r", "sigma_a", "length"]
    fig, axes = plt.subplots(1, 4, figsize=(14, 3.2))
    pitches = [r["pitch"] for r in rows]
    for ax, name in zip(axes, names):
        s = [r["summary"] for r in rows]
        mean = np.array([x[name].mean for x in s])
        lo, hi = np.array([x[name].q2_5 for x in s]), np.array([x[name].q97_5 for x in s])
        ax.errorbar(pitches, mean, yerr=[mean - lo, hi - mean], fmt="o", capsize=3)
        ax.set_xscale("log")
        ax.set_xlabel("pitch [m]")
        ax.set_title(name)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--pitches", type=float, nargs="+", default=[0.1, 0.05, 0.01, 0.005])
    parser.add_argument("--out", type=Path, default=Path("studies/out/c_dense"))
    parser.add_argument("--max-fun-evals", type=int, default=150)
    parser.add_argument("--n-predict", type=int, default=1000)
    args = parser.parse_args()
    if os.environ.get("TORCHSHM_SMOKE") == "1":  # a check that it runs (docs test), not the study
        args.pitches, args.max_fun_evals, args.n_predict = args.pitches[:1], min(args.max_fun_evals, 20), 100
        args.out = args.out.with_name(args.out.name + "_smoke")
        print(f"TORCHSHM_SMOKE=1: pitch {args.pitches[0]} only, VBMC {args.max_fun_evals} evaluations, into {args.out}")
    args.out.mkdir(parents=True, exist_ok=True)
    rows = []
    for pitch in args.pitches:
        rows.append(run_pitch(pitch, args))
        (args.out / "table.md").write_text(table(rows))  # kept after every pitch
        print(table(rows), flush=True)
    figure(rows, args.out / "fig.png")


if __name__ == "__main__":
    main()

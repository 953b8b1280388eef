"""Assemble the tables and figures of study B or C from the run folders of a sweep.

    python studies/collect_study.py runs/study_b/<stamp> --study b
    python studies/collect_study.py runs/study_c/<stamp> --study c

Reads every run folder (``run.json``, ``posterior.nc``, and the run's evaluation store
``evaluations.sqlite``), computes what the runs did not record (the KL divergence of Eq. 19 from
the saved variational posterior; for Fig. 9 the posterior predictive of load 55.1 from the
stored model outputs, with no new model evaluation), and writes into the sweep folder:

- ``study_<b|c>.md``: the tables (B: 8, 9, 10, KL, the emulator check; C: 8-like summary, 12,
  13 at the run's resolution and at every 0.1 m position) and run statistics;
- ``bayes_factors.csv`` (B), ``figure7.png`` and ``figure9.png`` (B) or ``figure11.png`` (C);
  Fig. 7 compares the emulator with the model, so it costs 100 model evaluations;
- ``hparams/``: TensorBoard hparams view (kernel, resolution against ELBO, coverage, KL).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import torchshm  # noqa: E402
import study_tables as study  # noqa: E402  (beside this file)
from torchshm.predictive import kl_divergence, posterior_predictive  # noqa: E402

KERNEL_ORDER = ["independent", "exponential", "matern32", "matern52", "squared_exponential"]
STORE_NAME = "evaluations.sqlite"


def measurements_of(settings: dict[str, Any]) -> Any:
    """All load cases of the run's data at the run's resolution."""
    data = settings["data"]
    if data.get("path"):
        meas = torchshm.load_measurements(data["path"])
    else:
        meas = torchshm.synthetic_campaign(seed=int(data.get("campaign_seed", 0)))
    return meas if data.get("resolution") is None else meas.downsample(float(data["resolution"]))


def rebuild_problem(rec: study.RunRecord, post: Any, settings: dict[str, Any]) -> Any:
    """The run's Problem on its evaluation store (its priors from the saved posterior)."""
    store = rec.path / STORE_NAME
    if not store.exists():
        raise FileNotFoundError(f"{store} is missing: run the sweep with store=${{hydra:runtime.output_dir}}/{STORE_NAME}")
    from torchshm.cli.models import instantiate_model

    model = instantiate_model(settings["model"], Path.cwd())
    meas = measurements_of(settings).select(rec.inference_loads)
    lik = settings["likelihood"]
    return torchshm.Problem(model, meas, kernel=rec.kernel, priors=post.priors, sigma_m=lik["sigma_m"],
                            sigma_e=lik["sigma_e"], store=store)


def add_kl(records: list[study.RunRecord], n: int = 10_000) -> None:
    """Fill ``rec.kl`` from each run's saved variational posterior (VBMC runs only)."""
    for rec in records:
        if rec.kl is None and rec.method == "vbmc":
            est = kl_divergence(torchshm.load_posterior(rec.path / "posterior.nc"), n=n, seed=0)
            rec.kl, rec.kl_se = est.value, est.se


def figure9(records: list[study.RunRecord], settings: dict[Path, dict], path: Path, load: float = 55.1) -> Path:
    """Predictive strain along the fibre with its 95 % band and the measurements (Fig. 9)."""
    chosen = [r for k in ("independent", "matern32") for r in records if r.kernel == k]
    fig, axes = plt.subplots(len(chosen), 1, figsize=(8, 2.6 * len(chosen)), sharex=True, squeeze=False,
                             constrained_layout=True)
    for ax, rec in zip(axes[:, 0], chosen):
        post = torchshm.load_posterior(rec.path / "posterior.nc")
        problem = rebuild_problem(rec, post, settings[rec.path])
        pred = posterior_predictive(post, [load], n=2000, seed=0, problem=problem)
        if problem.n_model_evaluations:
            raise RuntimeError("the posterior predictive evaluated the model")
        meas = measurements_of(settings[rec.path]).select([load])
        ax.plot(meas.x, meas.y[0], ".", ms=2, color="C1", label="measurements")
        ax.plot(pred.x, pred.mean[0], color="C0", lw=1, label="predictive mean")
        ax.fill_between(pred.x, pred.lower[0], pred.upper[0], color="C0", alpha=0.3, lw=0, label="95 % interval")
        cov = rec.scores(loads=[load])["coverage"]
        ax.set_title(f"{rec.kernel}: load {load:g} m (not used for inference), coverage {100 * cov:.1f} %",
                     fontsize="medium")
        ax.set_ylabel("strain [µε]")
    axes[0, 0].legend(frameon=False, fontsize="small", ncol=3)
    axes[-1, 0].set_xlabel("x [m]")
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def figure7(rec: study.RunRecord, settings: dict[str, Any], path: Path, loads: list[float]) -> str:
    """Emulator against the model on and outside the 99 % region (Fig. 7); evaluates the model."""
    from torchshm.predictive import emulator_check

    post = torchshm.load_posterior(rec.path / "posterior.nc")
    check = emulator_check(post, loads, problem=rebuild_problem(rec, post, settings))
    fig, axes = plt.subplots(1, 2, figsize=(9, 4), constrained_layout=True)
    groups = (("on the boundary of the 99 % region", check.boundary_exact, check.boundary_emulated),
              ("outside the 99 % region", check.outside_exact, check.outside_emulated))
    for ax, (title, exact, emulated) in zip(axes, groups):
        ax.plot(exact.flatten(), emulated.flatten(), ".", ms=1, alpha=0.4)
        ends = [float(exact.min()), float(exact.max())]
        ax.plot(ends, ends, "k-", lw=0.7)
        ax.set_title(f"{title}\nmax |error| {float((emulated - exact).abs().max()):.3g} µε", fontsize="medium")
        ax.set_xlabel("model strain [µε]")
    axes[0].set_ylabel("emulated strain [µε]")
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return (f"{rec.kernel}, loads {', '.join(f'{v:g}' for v in loads)} m, {check.boundary_theta.shape[0]} draws per "
            f"group: max |emulator - model| {check.boundary_error:.3g} µε on the boundary of the 99 % region, "
            f"{check.outside_error:.3g} µε outside it.")


def full_resolution_table(records: list[study.RunRecord], settings: dict[Path, dict], load: float) -> str:
    """Table 13 at every fibre position (0.1 m), whatever the run's resolution (no model run)."""
    from torchshm.predictive import predictive_metrics

    lines = ["| run | R² | MSE [µε²] | mean C.I. width [µε] | coverage |", "|---|---|---|---|---|"]
    for rec in records:
        post = torchshm.load_posterior(rec.path / "posterior.nc")
        problem = rebuild_problem(rec, post, settings[rec.path])
        pred = posterior_predictive(post, [load], n=2000, seed=0, problem=problem, positions="model")
        full = dict(settings[rec.path], data={**settings[rec.path]["data"], "resolution": None})
        m = predictive_metrics(pred, measurements_of(full), [load])
        lines.append(f"| {rec.resolution:g} m | {m.r2:.3f} | {m.mse:.3f} | {m.mean_width:.3f} | {100 * m.coverage:.2f} % |")
    return "\n".join(lines)


def figure11(records: list[study.RunRecord], path: Path, truths: dict[str, Any] | None = None) -> Path:
    """95 % posterior intervals of each parameter against the resolution (Fig. 11).

    ``truths``: attributes ``truth_<name>`` of a synthetic campaign, drawn as dashed lines.
    """
    fig, axes = plt.subplots(1, len(study.PARAMETERS), figsize=(13, 3.2), constrained_layout=True)
    res = np.array([r.resolution for r in records], dtype=float)
    for ax, (name, unit) in zip(axes, study.PARAMETERS):
        rows = [r.summary.get(name) for r in records]
        if any(s is None for s in rows):
            continue
        mean = np.array([s["mean"] for s in rows])
        lo, hi = np.array([s["q2.5"] for s in rows]), np.array([s["q97.5"] for s in rows])
        ax.errorbar(res, mean, yerr=[mean - lo, hi - mean], fmt="o", capsize=4)
        truth = (truths or {}).get(f"truth_{name}")
        if isinstance(truth, (int, float)):
            ax.axhline(float(truth), color="k", ls="--", lw=0.8, label="truth")
            ax.legend(frameon=False, fontsize="small")
        ax.set_xscale("log")
        ax.set_xticks(res, [f"{v:g}" for v in res])
        ax.set_xlabel("resolution [m]")
        ax.set_title(f"{name} [{unit}]", fontsize="medium")
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def write_hparams(records: list[study.RunRecord], out: Path) -> Path:
    """One TensorBoard hparams entry per run: kernel and resolution against the scores."""
    import shutil

    from torch.utils.tensorboard import SummaryWriter

    shutil.rmtree(out, ignore_errors=True)  # a second collection replaces the first

    for rec in records:
        held = rec.scores(held_out=True)
        metrics = {"hparam/elbo": np.nan if rec.log_evidence is None else rec.log_evidence,
                   "hparam/coverage_inference": rec.scores(held_out=False)["coverage"],
                   "hparam/coverage_heldout": held["coverage"], "hparam/r2_heldout": held["r2"],
                   "hparam/kl": np.nan if rec.kl is None else rec.kl,
                   "hparam/model_evaluations": float(rec.n_model_evaluations)}
        hparams = {"kernel": rec.kernel, "resolution": float(rec.resolution or 0.0), "method": rec.method}
        with SummaryWriter(log_dir=str(out / rec.path.name)) as writer:
            writer.add_hparams(hparams, {k: float(v) for k, v in metrics.items()}, run_name=".")
    return out


def collect(sweep_dir: Path, which: str) -> str:
    """Build every table and figure of study ``which`` ("b" or "c"); returns the markdown."""
    import json

    records = study.read_sweep(sweep_dir)
    if not records:
        raise SystemExit(f"collect_study: no run.json under {sweep_dir}")
    settings = {r.path: json.loads((r.path / "run.json").read_text())["settings"] for r in records}
    add_kl(records)
    if which == "b":
        records = study.order_records(records, lambda r: r.kernel, KERNEL_ORDER)
        label = lambda r: r.kernel  # noqa: E731
        bf = study.evidence_table(records, label)
        bf.to_csv(sweep_dir / "bayes_factors.csv")
        figure9(records, settings, sweep_dir / "figure9.png")
        ref = next(r for r in records if r.kernel == "matern32")
        check = figure7(ref, settings[ref.path], sweep_dir / "figure7.png", [55.1, 70.4])
        parts = [("Table 8: posterior mean [2.5 %, 97.5 %]", study.parameter_table(records, label)),
                 ("Table 9: log10 Bayes factors, row over column", bf.to_markdown()),
                 ("Table 10: coverage of the 95 % predictive interval", study.coverage_table(records, label)),
                 ("KL divergence", study.kl_table(records, label)),
                 ("Emulator check (Fig. 7)", check)]
    else:
        records = sorted(records, key=lambda r: float(r.resolution or 0.0))
        label = lambda r: f"{r.resolution:g} m"  # noqa: E731
        figure11(records, sweep_dir / "figure11.png", measurements_of(settings[records[0].path]).attrs)
        load = records[0].held_out_loads()[0]
        parts = [("Posterior mean [2.5 %, 97.5 %] (Fig. 11)", study.parameter_table(records, label)),
                 ("Table 12: KL divergence", study.kl_table(records, label)),
                 (f"Table 13: prediction of load {load:g} m at the run's resolution",
                  study.prediction_table(records, label, load)),
                 (f"Table 13 at every 0.1 m position: load {load:g} m",
                  full_resolution_table(records, settings, load))]
    parts.append(("Runs", study.run_table(records, label)))
    write_hparams(records, sweep_dir / "hparams")
    text = "\n\n".join(f"### {title}\n\n{table}" for title, table in parts) + "\n"
    (sweep_dir / f"study_{which}.md").write_text(text)
    return text


def run_sweep(name: str, overrides: list[str], argv: list[str] | None) -> None:
    """Launch one ``torchshm-identify`` multirun (joblib launcher) and collect study ``name``.

    Command-line options: ``--n-jobs`` (2), ``--out`` (``runs/study_<name>/<time>``), and any
    further Hydra overrides (e.g. ``method.max_fun_evals=60 predict.n=500``), appended last.
    """
    import subprocess
    import time

    parser = argparse.ArgumentParser(description=f"study {name.upper()}: one multirun, then the tables")
    parser.add_argument("--n-jobs", type=int, default=2)
    parser.add_argument("--out", type=Path, default=None)
    args, extra = parser.parse_known_args(argv)
    out = args.out or Path("runs") / f"study_{name}" / time.strftime("%Y-%m-%d_%H-%M-%S")
    command = [sys.executable, str(Path(__file__).resolve().parents[1] / "scripts" / "identify.py"), "-m", *overrides,
               "hydra/launcher=joblib", f"hydra.launcher.n_jobs={args.n_jobs}", f"hydra.sweep.dir={out}",
               f"store=${{hydra:runtime.output_dir}}/{STORE_NAME}",
               "hydra.job.config.override_dirname.exclude_keys=[store,data.loads,predict.loads]", *extra]
    print("+", " ".join(command), flush=True)
    start = time.perf_counter()
    subprocess.run(command, check=True)
    swept = time.perf_counter() - start
    text = collect(out, name)
    total = time.perf_counter() - start
    timing = f"sweep {swept:.0f} s, tables and figures {total - swept:.0f} s, total {total:.0f} s"
    (out / f"study_{name}.md").write_text(text + f"\nWall time: {timing} ({args.n_jobs} jobs).\n")
    print(text + f"\nWall time: {timing}; outputs in {out}")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sweep_dir", type=Path)
    parser.add_argument("--study", choices=["b", "c"], required=True)
    args = parser.parse_args(argv)
    print(collect(args.sweep_dir, args.study))


if __name__ == "__main__":
    main(sys.argv[1:])

"""Render the shipped synthetic campaign against the model at the true parameters.

Writes a figure of all 12 load cases (measured strains, the model at the truth, the pier
positions) and prints the peak strains per load case and the truth-minus-model discrepancy.

Usage: ``python scripts/render_campaign.py [--seed 0] [--output runs/campaign/campaign_vs_model.png]
[--sensitivity docs/figures/model_sensitivity.png]``
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import torch  # noqa: E402

from torchshm.casestudy.campaign import campaign_truth, discrepancy_summary, synthetic_campaign  # noqa: E402
from torchshm.casestudy import Bridge705, bridge705  # noqa: E402


def plot_load_cases(
    x: np.ndarray, loads: np.ndarray, measured: np.ndarray, model: np.ndarray, piers: np.ndarray, path: Path
) -> None:
    """All load cases, measured (`L x n`) against the model (`L x n`) [µε], to `path`."""
    fig, axes = plt.subplots(4, 3, figsize=(13, 11), sharex=True)
    for l, ax in enumerate(axes.flat):
        for pier in piers[(piers > x[0]) & (piers < x[-1])]:
            ax.axvline(pier, color="0.7", lw=0.8, ls=":")
        ax.plot(x, measured[l], color="tab:orange", lw=0.9, label="synthetic measurement")
        ax.plot(x, model[l], color="tab:blue", lw=1.1, label="model at the truth")
        ax.set_title(f"$T_{{1,{loads[l]:g}}}$", fontsize=10)
        ax.grid(alpha=0.3)
    for ax in axes[-1]:
        ax.set_xlabel("x [m]")
    for ax in axes[:, 0]:
        ax.set_ylabel("strain [µε]")
    axes[0, 0].legend(fontsize=8, loc="best")
    fig.suptitle(
        "Bridge 705, truck T1: bottom-fibre strain, synthetic campaign vs model at the truth "
        "(E_c = 35 GPa, log10 K_r = 11.5)",
        fontsize=10,
    )
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_sensitivity(model: Bridge705, path: Path, load: float = 55.1) -> None:
    """Strains of one load case for several E_c and log10 K_r, to `path`."""
    index = int(np.argmin(np.abs(model.loads.numpy() - load)))
    x = model.x.numpy()
    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 4), sharey=False)
    for E_c in (20.0, 35.0, 60.0):
        left.plot(x, model(torch.tensor([E_c, 11.5]))[index].numpy(), label=f"E_c = {E_c:g} GPa")
    reference = model(torch.tensor([35.0, 11.5]))[index].numpy()
    for log10_K_r in (0.0, 9.0, 10.0, 11.0, 12.0, 13.0):
        delta = model(torch.tensor([35.0, log10_K_r]))[index].numpy() - reference
        right.plot(x, delta, label=f"log10 K_r = {log10_K_r:g}")
    left.set_title(f"$T_{{1,{load:g}}}$, log10 K_r = 11.5", fontsize=10)
    right.set_title(f"$T_{{1,{load:g}}}$, E_c = 35 GPa: change from log10 K_r = 11.5", fontsize=10)
    for ax, label in ((left, "strain [µε]"), (right, "strain change [µε]")):
        ax.set_xlabel("x [m]")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--output", type=Path, default=Path("runs/campaign/campaign_vs_model.png"))
    parser.add_argument("--sensitivity", type=Path, default=None, help="also write a parameter-sensitivity figure")
    args = parser.parse_args()

    measurements = synthetic_campaign(args.seed)
    truth = campaign_truth()
    model = bridge705()
    theta = torch.tensor([measurements.attrs["truth_E_c"], measurements.attrs["truth_log10_K_r"]])
    eta = model(theta).numpy()
    plot_load_cases(measurements.x, measurements.loads, measurements.y, eta, model.config.pier_x(), args.output)
    print(f"wrote {args.output}")
    print("load [m]  peak |model| [µε]  peak |truth| [µε]  peak |measured| [µε]  rms(truth - model) [µε]")
    for l, load in enumerate(measurements.loads):
        rms_l = np.sqrt(np.mean((truth.strain[l] - eta[l]) ** 2))
        print(f"{load:8.1f}  {np.abs(eta[l]).max():17.2f}  {np.abs(truth.strain[l]).max():17.2f}  "
              f"{np.abs(measurements.y[l]).max():20.2f}  {rms_l:23.3f}")
    rms, length = discrepancy_summary(truth.strain - eta, 0.1)
    rms_y, length_y = discrepancy_summary(measurements.y - eta, 0.1)
    print(f"discrepancy truth - model: rms {rms:.3f} µε, correlation length {length:.2f} m")
    print(f"measured - model (seed {args.seed}): rms {rms_y:.3f} µε, correlation length {length_y:.2f} m")
    if args.sensitivity is not None:
        plot_sensitivity(model, args.sensitivity)
        print(f"wrote {args.sensitivity}")


if __name__ == "__main__":
    main()

"""Predictive maps of a held-out load case from a run of the camera example.

    python examples/plate_dic_camera/maps.py RUN_DIR [--load 1.0] [--draws 200]

Eq. (21) at a load case the run did not see: its discrepancy is a new draw of the GP (the
discrepancy is independent between load cases), so the predictive of each point is
``eta(theta) + delta + eps`` with ``theta`` from the posterior: mean ``E[eta]`` and
variance ``Var[eta] + E[sigma_m² eta² + sigma_a²] + sigma_e²``. The field's own correlation
does not change these pointwise maps; the model runs are one batch of posterior draws, no new
model is fitted. Writes ``maps_<load>.png`` into the run folder: the measured field, the
predictive mean, the predictive sd and the standardised residual ``(measured - mean) / sd``,
and prints the fraction of valid points within the central 95 % interval.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import torch  # noqa: E402
import yaml  # noqa: E402

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))

import torchshm  # noqa: E402
from examples.plate_dic_camera.camera import CameraPlate  # noqa: E402


def predictive(run: Path, load: float, draws: int, seed: int = 0) -> dict[str, np.ndarray]:
    """Measured field, predictive mean and sd [µε] `n`, and the points `n x 2` [m]."""
    post = torchshm.load_posterior(run / "posterior.nc")
    settings = yaml.safe_load((run / ".hydra" / "config.yaml").read_text())
    spec = {k: v for k, v in settings["model"].items() if k != "_target_"}
    model = CameraPlate(**spec)
    data = settings["data"]
    measured = torchshm.load_measurements(data["path"], "dic", **data["dic"]).select([load])
    index = {tuple(p): i for i, p in enumerate(np.round(model.x.numpy() / 1e-9).astype(np.int64).tolist())}
    where = np.array([index[tuple(p)] for p in np.round(measured.x / 1e-9).astype(np.int64).tolist()])
    theta = post.sample(draws, rng=seed)
    names = list(post.names)
    physical = torch.as_tensor(theta[:, [names.index(n) for n in model.names]])
    k = int(np.argmin(np.abs(model.loads.numpy() - load)))
    eta = model(physical)[:, k, where].numpy()  # draws x n
    sigma_m = float(settings["likelihood"]["sigma_m"])
    sigma_e = settings["likelihood"]["sigma_e"]
    sigma_e = measured.sigma_e if sigma_e is None else float(sigma_e)
    var = eta.var(axis=0) + (sigma_m**2 * eta**2).mean(axis=0) + (theta[:, names.index("sigma_a")] ** 2).mean() \
        + sigma_e**2
    return {"x": measured.x, "measured": measured.y[0], "mean": eta.mean(axis=0), "sd": np.sqrt(var)}


def plot(maps: dict[str, np.ndarray], load: float, path: Path) -> float:
    """Four maps into `path`; returns the fraction of valid points in the 95 % interval."""
    z = (maps["measured"] - maps["mean"]) / maps["sd"]
    ok = np.isfinite(z)
    inside = float(np.mean(np.abs(z[ok]) < 1.96))
    fig, axes = plt.subplots(2, 2, figsize=(11, 7.5), sharex=True, sharey=True)
    lim = np.nanpercentile(np.abs(maps["measured"]), 99.5)
    panels = [("measured eps_xx (DIC) [µε]", maps["measured"], "RdBu_r", (-lim, lim)),
              ("predictive mean [µε]", maps["mean"], "RdBu_r", (-lim, lim)),
              ("predictive sd [µε]", maps["sd"], "viridis", (None, None)),
              (f"(measured - mean) / sd: {100 * inside:.1f} % within ±1.96", z, "RdBu_r", (-4, 4))]
    xs, ys = np.unique(maps["x"][:, 0]), np.unique(maps["x"][:, 1])
    ix, iy = np.searchsorted(xs, maps["x"][:, 0]), np.searchsorted(ys, maps["x"][:, 1])
    extent = (xs[0], xs[-1], ys[0], ys[-1])
    for ax, (title, values, cmap, (lo, hi)) in zip(axes.flat, panels):
        image = np.full((ys.size, xs.size), np.nan)
        image[iy, ix] = values  # lost subsets stay blank
        art = ax.imshow(image, origin="lower", extent=extent, cmap=cmap, vmin=lo, vmax=hi, interpolation="nearest")
        ax.set_title(title, fontsize=10)
        ax.set_aspect("equal")
        fig.colorbar(art, ax=ax, shrink=0.8)
    for ax in axes[1]:
        ax.set_xlabel("x [m]")
    for ax in axes[:, 0]:
        ax.set_ylabel("y [m]")
    fig.suptitle(f"held-out load case {load:g} m: posterior predictive of the DIC field")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return inside


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", type=Path, help="the run folder of torchshm-identify")
    parser.add_argument("--load", type=float, default=1.0, help="held-out load case [m]")
    parser.add_argument("--draws", type=int, default=200, help="posterior draws")
    args = parser.parse_args()
    maps = predictive(args.run, args.load, args.draws)
    path = args.run / f"maps_{args.load:g}.png"
    inside = plot(maps, args.load, path)
    print(json.dumps({"maps": str(path), "points": int(np.isfinite(maps["measured"]).sum()),
                      "within_95": round(inside, 4)}))


if __name__ == "__main__":
    main()

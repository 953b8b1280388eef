"""Write ``dic/DICe_solution_<k>.txt.gz``: the plate's strain field measured by image correlation.

    python examples/plate_dic_camera/make_campaign.py      # from the repository root (~10 min)

1. The plate (``conf/model/plate_dic_camera.yaml``) at the true parameters gives the deflection
   of each load case; its bottom surface moves in plane by ``-(t/2) grad w``.
2. A camera of ``IMAGE`` pixels (``PIXEL`` m each) looks at the bottom surface, painted with a
   random speckle: a reference image, a second reference image (the noise floor) and one image
   per load case, each rendered at 3 x 3 sub-pixels, with two glare spots, read noise and 8-bit
   grey levels (:mod:`render`).
3. muDIC correlates them (Q4 elements of ``ELEMENT`` px, :mod:`correlate`); the strains at the
   element centres are carried onto a grid ``UPSCALE`` times finer (a point every 4 px), and
   points next to a glare-lost element are written as lost subsets (``SIGMA = -1``).
4. One file per load case in DICe's solution format (coordinates in px, strains in m/m), and
   ``truth.json`` with the true parameters, the settings and the measured noise floor.

The noise in the field is the correlation's own: nothing is added to the strains.
"""

from __future__ import annotations

import gzip
import json
import sys
import time
from pathlib import Path

import numpy as np
import yaml

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(ROOT))

from examples.plate_dic.plate import PlateDIC  # noqa: E402
from examples.plate_dic_camera import correlate, render  # noqa: E402

TRUTH = {"E": 3.2, "log10_k": 5.5}  # GPa, log10 N·m/rad/m
IMAGE = (1500, 2000)  # rows x columns [px]
PIXEL = 1e-3  # pixel size on the plate [m]
SUPERSAMPLE, SPECKLE_PX, NOISE = 3, 0.7, 0.005  # sub-pixels, speckle filter [px], read noise / 255
GLARE = [(1450.0, 420.0, 30.0), (620.0, 1120.0, 22.0)]  # (column, row, radius) [px]
CORNER, ELEMENT, N_EL, UPSCALE = (70, 70), 12, (155, 113), 3
REJECT = 3.0  # lost element: predicted displacement sd above REJECT x the median
SEED = 21


def plate_settings() -> dict:
    """The model's keyword arguments from ``conf/model/plate_dic_camera.yaml``."""
    spec = yaml.safe_load((HERE / "conf" / "model" / "plate_dic_camera.yaml").read_text())
    return {k: v for k, v in spec.items() if not k.startswith("_") and k not in ("grid", "element")}


def images(rng: np.random.Generator) -> tuple[list[np.ndarray], tuple[float, ...]]:
    """Reference, noise-floor reference and one image per load case (grey levels)."""
    kw = plate_settings()
    plate = PlateDIC(pitch=kw["cell"], **{k: (tuple(v) if isinstance(v, list) else v) for k, v in kw.items()})
    xs, ys, w = render.deflection(plate, (TRUTH["E"], TRUTH["log10_k"]), kw["patch"], kw["force"])
    pattern = render.speckle(IMAGE, SUPERSAMPLE, SPECKLE_PX, rng)
    bright = render.glare(IMAGE, GLARE)
    shots = [render.render(pattern, SUPERSAMPLE, PIXEL, None, bright, NOISE, rng) for _ in range(2)]
    for k in range(len(plate.loads)):
        field = render.surface_displacement(xs, ys, w[k], kw["thickness"])
        shots.append(render.render(pattern, SUPERSAMPLE, PIXEL, field, bright, NOISE, rng))
    return shots, tuple(float(v) for v in plate.loads)


def write_dice(path: Path, frame: int, columns: np.ndarray, rows: np.ndarray, sigma: np.ndarray,
               exx: np.ndarray) -> None:
    """One DICe solution file (gzip): points in px, strain ``VSG_STRAIN_XX`` in m/m, SIGMA -1 if lost."""
    head = ["***", "*** DICe solution format, written by examples/plate_dic_camera/make_campaign.py",
            f"*** Correlation: muDIC Q4, element {ELEMENT} px, strains at element centres upscaled x{UPSCALE}",
            f"*** Frame: {frame}", "***",
            "SUBSET_ID,COORDINATE_X,COORDINATE_Y,SIGMA,VSG_STRAIN_XX"]
    lost = sigma < 0
    body = np.column_stack([np.arange(columns.size), columns, rows, np.where(lost, -1.0, sigma),
                            np.where(lost, 0.0, exx)])
    with gzip.open(path, "wt", encoding="utf-8", compresslevel=9) as f:
        f.write("\n".join(head) + "\n")
        np.savetxt(f, body, delimiter=",", fmt=["%d", "%.0f", "%.0f", "%.2e", "%.3e"])


def main() -> None:
    rng = np.random.default_rng(SEED)
    t0, c0 = time.perf_counter(), time.process_time()
    shots, loads = images(rng)
    t_render = time.perf_counter() - t0
    strain = correlate.correlate(shots, CORNER, ELEMENT, N_EL)  # 3 x nx x ny x frames
    t_dic = time.perf_counter() - t0 - t_render
    sigma = correlate.element_sigma(shots[0], CORNER, ELEMENT, N_EL, NOISE * 255.0)
    lost = ~(sigma <= REJECT * np.median(sigma)) | ~np.isfinite(strain[0]).all(axis=-1)
    lost_up = correlate.upscale(lost.astype(float), UPSCALE) > 0
    sigma_up = np.where(lost_up, -1.0, correlate.upscale(np.where(lost, 0.0, sigma), UPSCALE))
    exx = np.nan_to_num(strain[0])
    up = [correlate.upscale(exx[..., f], UPSCALE) for f in range(exx.shape[-1])]
    step = ELEMENT / UPSCALE
    cols = CORNER[0] + ELEMENT / 2 + step * np.arange(up[0].shape[0])
    rows = CORNER[1] + ELEMENT / 2 + step * np.arange(up[0].shape[1])
    gc, gr = np.meshgrid(cols, rows, indexing="ij")
    out = HERE / "dic"
    out.mkdir(exist_ok=True)
    for k in range(len(loads)):
        write_dice(out / f"DICe_solution_{k}.txt.gz", k + 2, gc.reshape(-1), gr.reshape(-1),
                   sigma_up.reshape(-1), up[k + 2].reshape(-1))
    valid = ~lost_up
    floor_up, floor_el = 1e6 * np.std(up[1][valid]), 1e6 * np.std(exx[..., 1][~lost])
    truth = {**{f"truth_{k}": v for k, v in TRUTH.items()}, "loads": list(loads),
             "files": [f"dic/DICe_solution_{k}.txt.gz" for k in range(len(loads))],
             "image_px": list(IMAGE), "pixel_m": PIXEL, "element_px": ELEMENT, "upscale": UPSCALE,
             "elements": list(N_EL), "points": int(up[0].size), "lost_points": int(lost_up.sum()),
             "noise_floor_ue": round(float(floor_up), 1), "noise_floor_element_ue": round(float(floor_el), 1),
             "read_noise": NOISE, "seed": SEED, "render_s": round(t_render, 1), "dic_s": round(t_dic, 1),
             "cpu_s_main": round(time.process_time() - c0, 1)}
    (HERE / "truth.json").write_text(json.dumps(truth, indent=1) + "\n")
    print(json.dumps(truth, indent=1))


if __name__ == "__main__":
    main()

"""How much the camera field tells about ``E`` and ``log10_k``: the element noise, measured.

    python examples/plate_dic_camera/information.py     # from the repository root (~10 s)

At the element centres (every third point of the files: 155 x 113 per image) the residual
against the model at the truth (``truth.json``; the model gives the correlation's strain,
``conf/model/plate_dic_camera.yaml``) is the correlation's noise. The script prints its sd, its
correlation at neighbouring elements, the share of its spectrum at wavenumber 0, and for the
inference load cases (0.5, 1.5 m) the least-squares estimate of ``(E, log10_k)`` with
independent elements (what ``kernel=upscaled`` assumes): its offset from the truth, the sd that
assumption claims, and its actual sd under the measured (stationary, 13 x 13 lags)
correlation, ``(JᵀJ)⁻¹ Jᵀ Σ J (JᵀJ)⁻¹``.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import torch
import yaml
from scipy import signal

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))

from examples.plate_dic_camera.camera import CameraPlate  # noqa: E402
from torchshm.data.dic import read_dic  # noqa: E402

LAGS = 6  # elements each way


def main() -> None:
    truth = json.loads((HERE / "truth.json").read_text())
    spec = yaml.safe_load((HERE / "conf" / "model" / "plate_dic_camera.yaml").read_text())
    spec.pop("_target_")
    model, (nx, ny) = CameraPlate(**spec), (spec["grid"]["nx"], spec["grid"]["ny"])
    data = yaml.safe_load((HERE / "conf" / "data" / "plate_dic_camera.yaml").read_text())["dic"]
    field = read_dic(str(HERE / "dic" / "DICe_solution_*.txt.gz"), loads=data["loads"], preset="dice",
                     scale=data["scale"], sigma_e=data["sigma_e"])
    step = truth["upscale"]
    centres = np.asarray(field.y).reshape(-1, nx, ny)[:, ::step, ::step]

    def at(theta: np.ndarray) -> np.ndarray:
        return model(torch.tensor(theta)).numpy().reshape(-1, nx, ny)[:, ::step, ::step]

    t0 = np.array([truth["truth_E"], truth["truth_log10_k"]])
    jac = np.stack([(at(t0 + 1e-3 * e) - at(t0 - 1e-3 * e)) / 2e-3 for e in np.eye(2)], -1)
    resid, loads = centres - at(t0), [0, 2]
    ok = np.isfinite(resid)
    acov = np.zeros((2 * LAGS + 1, 2 * LAGS + 1))
    for k in loads:
        r, m = np.where(ok[k], resid[k], 0.0), ok[k].astype(float)
        num, den = (signal.correlate(a, a, mode="full", method="fft") for a in (r, m))
        c = np.array(r.shape) - 1
        acov += (num / np.maximum(den, 1.0))[c[0] - LAGS:c[0] + LAGS + 1, c[1] - LAGS:c[1] + LAGS + 1] / len(loads)
    var = acov[LAGS, LAGS]
    near = {f"{i},{j}": round(acov[LAGS + i, LAGS + j] / var, 3) for i, j in ((1, 0), (0, 1), (1, 1), (2, 0), (0, 2))}
    jtj = sum(np.einsum("ni,nj->ij", jac[k][ok[k]], jac[k][ok[k]]) for k in loads)
    jsj = np.zeros((2, 2))
    for k in loads:
        for i in range(2):
            sj = signal.fftconvolve(np.where(ok[k], jac[k][..., i], 0.0), acov, mode="same") * ok[k]
            jsj[i] += [(sj * np.where(ok[k], jac[k][..., j], 0.0)).sum() for j in range(2)]
    inv = np.linalg.inv(jtj)
    offset = inv @ sum(jac[k][ok[k]].T @ resid[k][ok[k]] for k in loads)
    print(json.dumps({
        "element_sd_ue": round(float(np.sqrt(var)), 1), "correlation_at_lags_x_y": near,
        "spectrum_at_0_over_variance": round(float(acov.sum() / var), 3),
        "offset_from_truth": offset.round(4).tolist(),
        "sd_claimed_independent": np.sqrt(np.diag(var * inv)).round(4).tolist(),
        "sd_actual": np.sqrt(np.diag(inv @ jsj @ inv)).round(4).tolist(),
    }, indent=1))


if __name__ == "__main__":
    main()

"""The camera example's measurement operator against the renderer's own surface and muDIC's
upscaling, evaluated directly (scipy's bicubic spline, one element at a time)."""

from __future__ import annotations

import numpy as np
import torch
from scipy.interpolate import RectBivariateSpline

from examples.plate_dic_camera.correlate import upscale
from examples.plate_dic_camera.measure import Correlation

GRID = {"x0": 0.2, "y0": 0.1, "dx": 0.004, "dy": 0.004, "nx": 13, "ny": 10}
ELEMENT, THICKNESS = 0.012, 0.1


def test_strains_are_the_q4_element_strains_of_the_rendered_surface(rng: np.random.Generator) -> None:
    """Element strain ``(u(x + l/2) - u(x - l/2)) / l`` on the two edges ``y -+ l/2`` of the
    spline surface ``u = -(t/2) dw/dx``, as ``ln(1 + eps)``, bilinear between centres (1e-9 µε)."""
    xs, ys = np.linspace(0.0, 0.5, 17), np.linspace(0.0, 0.375, 13)
    w = 1e-4 * rng.normal(size=(xs.size, ys.size))  # m: strains of a few thousand µε
    spline = RectBivariateSpline(xs, ys, w, kx=3, ky=3, s=0)
    cx, cy = GRID["x0"] + ELEMENT * np.arange(5), GRID["y0"] + ELEMENT * np.arange(4)
    elements = np.zeros((5, 4))
    for i, x in enumerate(cx):
        for j, y in enumerate(cy):
            u = [-0.5 * THICKNESS * spline.ev(x + s * ELEMENT / 2, y + e * ELEMENT / 2, dx=1) for s in (-1, 1) for e in (-1, 1)]
            elements[i, j] = np.log1p(((u[2] - u[0]) + (u[3] - u[1])) / (2 * ELEMENT))
    want = 1e6 * upscale(elements, 3).reshape(-1)
    got = Correlation(xs, ys, GRID, ELEMENT, THICKNESS)(w[None])[0]
    np.testing.assert_allclose(got, want, atol=1e-9)


def test_camera_plate_gives_the_correlation_strains_at_every_point() -> None:
    from examples.plate_dic_camera.camera import CameraPlate

    grid = {"x0": 0.076, "y0": 0.076, "dx": 0.004, "dy": 0.004, "nx": 31, "ny": 25}
    plate = {"size": [2.0, 1.5], "thickness": 0.1, "poisson": 0.3, "cell": 0.0625, "patch": 0.25,
             "force": 150000.0, "loads": [0.5, 1.0]}
    own, measured = CameraPlate(grid, **plate), CameraPlate(grid, element=ELEMENT, **plate)
    theta = torch.tensor([[3.2, 5.5], [4.0, 6.0]], dtype=torch.float64)
    a, b = own(theta), measured(theta)
    assert a.shape == b.shape == (2, 2, 31 * 25)
    assert float((a - b).abs().max()) < 0.05 * float(a.abs().max())  # the same field, measured

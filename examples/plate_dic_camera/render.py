"""Rendering the plate's bottom surface as a camera sees it: speckle, deformation, glare, noise.

- :func:`deflection`: the plate's deflection ``w`` [m] on its finite-difference nodes (edges
  included), the same equations as :class:`examples.plate_dic.plate.PlateDIC` solved directly.
- :func:`surface_displacement`: the in-plane displacement of the bottom surface,
  ``u = -(t/2) dw/dx``, ``v = -(t/2) dw/dy`` [m] (so that ``du/dx`` is the model's ``eps_xx``),
  from a bicubic spline of ``w``.
- :func:`speckle`: a random black-and-white speckle pattern, sampled ``S`` times finer than
  the camera's pixels; :func:`render` warps it by a displacement field, integrates each pixel
  over its ``S x S`` sub-pixels, adds glare (fixed in the image, not on the surface), Gaussian
  read noise and 8-bit quantisation.

Camera: the image column ``i`` and row ``j`` look at the point ``(i p, j p)`` of the plate
(pixel size ``p`` [m]).
"""

from __future__ import annotations

import numpy as np
import torch
from scipy import ndimage
from scipy.interpolate import RectBivariateSpline

from examples.plate_dic.plate import PlateDIC, second_difference


def deflection(plate: PlateDIC, theta: tuple[float, float], patch: float, force: float) -> tuple:
    """Nodes ``xs`` `nx + 1`, ``ys`` `ny + 1` [m] and deflection `(nx + 1) x (ny + 1)` [m]."""
    h, (a, b) = plate.h, plate.size
    nx, ny = round(a / h), round(b / h)
    lx, ly = second_difference(nx - 1), second_difference(ny - 1)
    eye_x, eye_y = torch.eye(nx - 1, dtype=torch.float64), torch.eye(ny - 1, dtype=torch.float64)
    laplace = torch.kron(lx, eye_y) + torch.kron(eye_x, ly)
    rigidity = theta[0] * plate.rigidity_per_gpa
    beta = 10.0 ** theta[1] * h / (2.0 * rigidity)
    stencil = laplace @ laplace + 2.0 * beta / (beta + 1.0) * plate._u @ plate._u.T
    gi, gj = torch.meshgrid(torch.arange(1, nx), torch.arange(1, ny), indexing="ij")
    q = plate._load_vectors(gi, gj, patch, force)  # N x L
    w = h**4 / rigidity * torch.linalg.solve(stencil, q)  # N x L
    full = torch.zeros(len(plate.loads), nx + 1, ny + 1, dtype=torch.float64)
    full[:, 1:nx, 1:ny] = w.T.reshape(-1, nx - 1, ny - 1)
    return np.arange(nx + 1) * h, np.arange(ny + 1) * h, full.numpy()


def surface_displacement(xs: np.ndarray, ys: np.ndarray, w: np.ndarray, thickness: float):
    """A function ``(x, y) [m] -> (u, v) [m]`` of the bottom surface, on points of any shape."""
    spline = RectBivariateSpline(xs, ys, w, kx=3, ky=3, s=0)

    def field(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return -0.5 * thickness * spline.ev(x, y, dx=1), -0.5 * thickness * spline.ev(x, y, dy=1)

    return field


def speckle(shape: tuple[int, int], supersample: int, size_px: float, rng: np.random.Generator) -> np.ndarray:
    """A speckle pattern in [0, 1] of `shape` camera pixels, sampled `supersample` times finer."""
    fine = (shape[0] * supersample, shape[1] * supersample)
    field = ndimage.gaussian_filter(rng.standard_normal(fine, dtype=np.float32), size_px * supersample)
    dots = (field > np.median(field)).astype(np.float32)
    return ndimage.gaussian_filter(dots, 0.6 * supersample)


def glare(shape: tuple[int, int], spots: list[tuple[float, float, float]]) -> np.ndarray:
    """`shape` weights in [0, 0.9]: Gaussian glare spots ``(column, row, radius)`` [px]."""
    rows, cols = np.mgrid[0:shape[0], 0:shape[1]].astype(np.float32)
    g = np.zeros(shape, np.float32)
    for c, r, radius in spots:
        g = np.maximum(g, np.exp(-0.5 * ((cols - c) ** 2 + (rows - r) ** 2) / radius**2))
    return 0.9 * g


def render(pattern: np.ndarray, supersample: int, pixel: float, field, bright: np.ndarray,
           noise: float, rng: np.random.Generator, chunk: int = 100) -> np.ndarray:
    """An 8-bit image `rows x cols` of the pattern displaced by ``field`` (``None``: undeformed).

    Args:
        pattern: the speckle `(rows S) x (cols S)`; supersample: ``S``; pixel: pixel size [m].
        field: ``(x, y) -> (u, v)`` [m] (:func:`surface_displacement`) or ``None``.
        bright: glare weights `rows x cols` (:func:`glare`); noise: read noise, fraction of 255.
    """
    s = supersample
    rows, cols = pattern.shape[0] // s, pattern.shape[1] // s
    sub = (np.arange(cols * s) + 0.5) / s - 0.5  # sub-pixel column positions [px]
    out = np.empty((rows, cols))
    for r0 in range(0, rows, chunk):
        r1 = min(rows, r0 + chunk)
        sub_r = (np.arange(r0 * s, r1 * s) + 0.5) / s - 0.5
        yy, xx = np.meshgrid(sub_r, sub, indexing="ij")
        if field is not None:  # the material point seen at x was at X = x - u(X): two fixed-point steps
            u, v = field(xx * pixel, yy * pixel)
            u, v = field((xx - u / pixel) * pixel, (yy - v / pixel) * pixel)
            xx, yy = xx - u / pixel, yy - v / pixel
        values = ndimage.map_coordinates(pattern, [(yy + 0.5) * s - 0.5, (xx + 0.5) * s - 0.5], order=1, mode="nearest")
        out[r0:r1] = values.reshape(r1 - r0, s, cols, s).mean(axis=(1, 3))
    grey = 20.0 + 200.0 * out
    grey = (1.0 - bright) * grey + bright * 250.0
    grey += noise * 255.0 * rng.standard_normal(grey.shape)
    return np.clip(np.round(grey), 0, 255)

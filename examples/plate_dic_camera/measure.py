"""What the image correlation measures of a deflection: the example's measurement operator.

The camera sees the bottom surface move in plane by ``u = -(t/2) dw/dx`` (``w``: the plate's
deflection, a bicubic interpolating spline of its finite-difference nodes, the surface the
images were rendered from); the Q4 correlation (muDIC) gives each element of side ``l`` the
strain of its four nodes' displacements, ``(u(x + l/2) - u(x - l/2)) / l`` averaged over the
element's two edges ``y -+ l/2``, as a true strain ``ln(1 + eps)``, and writes the field
bilinearly between the element centres (``Fields(upscale=...)``). Every step but the logarithm
is linear and separable in x and y: :class:`Correlation` holds the `1-D` matrices.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import make_interp_spline


def cardinal(nodes: np.ndarray, at: np.ndarray, nu: int) -> np.ndarray:
    """`len(at) x len(nodes)`: the ``nu``-th derivative at ``at`` of the cubic not-a-knot spline
    through each unit vector of the ``nodes`` (the 1-D factor of a bicubic interpolating spline)."""
    return make_interp_spline(nodes, np.eye(nodes.size), k=3)(at, nu=nu)


def linear(centres: int, factor: int) -> np.ndarray:
    """`((centres - 1) factor + 1) x centres`: linear interpolation between centres, ``factor``
    points per interval (muDIC's ``upscale``)."""
    f = np.arange((centres - 1) * factor + 1) / factor
    lo = np.minimum(np.floor(f).astype(int), centres - 2)
    out = np.zeros((f.size, centres))
    out[np.arange(f.size), lo] = 1.0 - (f - lo)
    out[np.arange(f.size), lo + 1] = f - lo
    return out


class Correlation:
    """The strains ``eps_xx`` [µε] the correlation writes on its grid, from nodal deflections.

    Args:
        xs, ys: the plate's finite-difference nodes each way [m], edges included.
        grid: the correlation points ``{x0, y0, dx, dy, nx, ny}`` [m] (the first point an
            element centre); element: the element side [m], a whole number of point pitches.
        thickness: plate thickness [m].
    """

    def __init__(self, xs: np.ndarray, ys: np.ndarray, grid: dict, element: float, thickness: float) -> None:
        self.thickness = float(thickness)
        ops = []
        for nodes, x0, d, n, edge in ((xs, grid["x0"], grid["dx"], grid["nx"], False),
                                      (ys, grid["y0"], grid["dy"], grid["ny"], True)):
            factor = round(element / d)
            if abs(factor * d - element) > 1e-9 or (n - 1) % factor:
                raise ValueError(f"element {element} m: not a whole number of pitches {d} m over {n} points")
            centres = x0 + element * np.arange((n - 1) // factor + 1)
            if edge:  # y: the mean of the element's two edges
                average = 0.5 * (cardinal(nodes, centres - element / 2, 0) + cardinal(nodes, centres + element / 2, 0))
            else:  # x: the difference quotient of the slope across the element
                average = (cardinal(nodes, centres + element / 2, 1) - cardinal(nodes, centres - element / 2, 1)) / element
            ops.append((average, linear(centres.size, factor)))
        (self._ax, self._ux), (self._ay, self._uy) = ops

    def __call__(self, w: np.ndarray) -> np.ndarray:
        """Strains `... x (nx ny)` [µε] (points sorted by x then y) of deflections `... x Nx x Ny` [m]."""
        eps = -0.5 * self.thickness * (self._ax @ w @ self._ay.T)  # element strains [-]
        out = self._ux @ (1e6 * np.log1p(eps)) @ self._uy.T
        return out.reshape(*w.shape[:-2], -1)

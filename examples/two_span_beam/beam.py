"""A two-span continuous beam crossed by a two-axle truck: the example's forward model.

A 2 x 20 m continuous beam (supports at 0, 20 and 40 m) with rotational springs at its two end
supports, modelled with Euler-Bernoulli beam elements. Three physical parameters:

- ``E``: Young's modulus [GPa] of the (uniform) section;
- ``log10_k_A``, ``log10_k_C``: log10 of the rotational stiffness [N·m/rad] of the end supports
  A (x = 0) and C (x = 40 m): about 5 is a pin, about 11 a clamp.

The output is the bottom-fibre strain [µε] at the sensor positions ``x`` for every load case
(the truck's front-axle position [m]), all at once, as a torchshm forward model must.
"""

from __future__ import annotations

import hashlib

import torch
from torch import Tensor

#: the truck: (offset behind the front axle [m], axle load [N])
AXLES = ((0.0, 100e3), (4.0, 150e3))


class TwoSpanBeam:
    """Forward model ``model(theta_p `... x 3`) -> strains `... x L x n` [µε]``.

    Args:
        spans: lengths of the two spans [m].
        element: beam element length [m]; must divide both spans.
        pitch: spacing of the sensor positions ``x`` [m].
        loads: front-axle positions [m] of the load cases.
        inertia: second moment of area of the section [m^4].
        depth_below: distance from the neutral axis to the fibre [m].
    """

    names = ("E", "log10_k_A", "log10_k_C")
    units = {"E": "GPa", "log10_k_A": "log10 N·m/rad", "log10_k_C": "log10 N·m/rad"}

    def __init__(
        self,
        spans: tuple[float, float] = (20.0, 20.0),
        element: float = 0.5,
        pitch: float = 0.1,
        loads: tuple[float, ...] = (6.0, 10.0, 14.0, 18.0, 22.0, 26.0, 30.0, 34.0, 38.0),
        inertia: float = 0.1,
        depth_below: float = 0.6,
    ) -> None:
        length = float(sum(spans))
        n_el = round(length / element)
        if any(abs(s / element - round(s / element)) > 1e-9 for s in spans):
            raise ValueError(f"element {element} m must divide the spans {spans}")
        self.h, self.inertia, self.c = length / n_el, float(inertia), float(depth_below)
        self.nodes = torch.linspace(0.0, length, n_el + 1, dtype=torch.float64)
        self.x = torch.round(torch.arange(0.0, length + pitch / 2, pitch, dtype=torch.float64) * 1e6) / 1e6
        self.loads = torch.as_tensor(loads, dtype=torch.float64)
        supports = [0, round(spans[0] / self.h), n_el]
        self._free = [d for d in range(2 * (n_el + 1)) if d % 2 or d // 2 not in supports]
        self._k0 = self._unit_stiffness(n_el)[self._free][:, self._free]
        self._spring = [self._free.index(1), self._free.index(2 * n_el + 1)]  # end rotations
        self._force = self._load_vectors()[self._free]  # M x L
        self._curv = self._curvature_matrix()  # n x 2(N+1)
        key = f"{spans}-{element}-{pitch}-{tuple(loads)}-{inertia}-{depth_below}"
        self.identity = f"TwoSpanBeam-{hashlib.sha256(key.encode()).hexdigest()[:12]}"

    def __call__(self, theta_p: object) -> Tensor:
        """Bottom-fibre strains `... x L x n` [µε] for ``(E, log10_k_A, log10_k_C)`` `... x 3`."""
        theta = torch.as_tensor(theta_p, dtype=torch.float64)
        if theta.shape[-1:] != (3,):
            raise ValueError(f"TwoSpanBeam: theta_p must end in 3 parameters {self.names}, got {tuple(theta.shape)}")
        flat = theta.reshape(-1, 3)
        ei = flat[:, 0] * 1e9 * self.inertia
        stiffness = ei[:, None, None] * self._k0
        springs = torch.zeros_like(stiffness)
        springs[:, self._spring[0], self._spring[0]] = 10.0 ** flat[:, 1]
        springs[:, self._spring[1], self._spring[1]] = 10.0 ** flat[:, 2]
        u_free = torch.linalg.solve(stiffness + springs, self._force.expand(len(flat), -1, -1))
        u = flat.new_zeros(len(flat), self._curv.shape[1], self._force.shape[1])
        u[:, self._free] = u_free
        strain = 1e6 * self.c * (self._curv @ u)  # B x n x L; sagging (w'' > 0) stretches the bottom
        return strain.transpose(-1, -2).reshape(*theta.shape[:-1], len(self.loads), len(self.x))

    def _unit_stiffness(self, n_el: int) -> Tensor:
        """Global stiffness for EI = 1, DOFs (w, rotation) per node, w upwards."""
        h = self.h
        ke = torch.tensor([[12, 6 * h, -12, 6 * h], [6 * h, 4 * h * h, -6 * h, 2 * h * h],
                           [-12, -6 * h, 12, -6 * h], [6 * h, 2 * h * h, -6 * h, 4 * h * h]],
                          dtype=torch.float64) / h**3
        k = torch.zeros(2 * (n_el + 1), 2 * (n_el + 1), dtype=torch.float64)
        for e in range(n_el):
            k[2 * e: 2 * e + 4, 2 * e: 2 * e + 4] += ke
        return k

    def _hermite(self, pos: float) -> tuple[int, float]:
        """Element index and local coordinate in [0, 1] of position ``pos``."""
        e = min(int(pos // self.h), len(self.nodes) - 2)
        return e, (pos - float(self.nodes[e])) / self.h

    def _load_vectors(self) -> Tensor:
        """Consistent nodal forces `2(N+1) x L` of the truck at each load case (downwards)."""
        f = torch.zeros(2 * len(self.nodes), len(self.loads), dtype=torch.float64)
        end = float(self.nodes[-1])
        for j, front in enumerate(self.loads.tolist()):
            for offset, weight in AXLES:
                pos = front - offset
                if not 0.0 <= pos <= end:
                    continue
                e, s = self._hermite(pos)
                shape = [1 - 3 * s**2 + 2 * s**3, self.h * (s - 2 * s**2 + s**3),
                         3 * s**2 - 2 * s**3, self.h * (s**3 - s**2)]
                f[2 * e: 2 * e + 4, j] -= weight * torch.tensor(shape, dtype=torch.float64)
        return f

    def _curvature_matrix(self) -> Tensor:
        """`n x 2(N+1)` matrix giving w'' [1/m] at the sensor positions from the DOFs."""
        b = torch.zeros(len(self.x), 2 * len(self.nodes), dtype=torch.float64)
        h = self.h
        for i, pos in enumerate(self.x.tolist()):
            e, s = self._hermite(pos)
            b[i, 2 * e: 2 * e + 4] = torch.tensor(
                [(-6 + 12 * s) / h**2, (-4 + 6 * s) / h, (6 - 12 * s) / h**2, (-2 + 6 * s) / h],
                dtype=torch.float64)
        return b

    def __repr__(self) -> str:
        return f"TwoSpanBeam(n={len(self.x)}, loads={len(self.loads)})"

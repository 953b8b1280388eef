"""A portal frame with semi-rigid beam-column joints, in OpenSeesPy: the example's forward model.

Columns 4 m high (0.4 x 0.4 m, bases clamped) at x = 0 and 8 m carry an 8 m beam
(0.3 m wide, 0.6 m deep); each beam end is joined to its column by a rotational spring of
stiffness ``k_j`` (a ``zeroLength`` element; translations tied by ``equalDOF``). A fibre-optic
sensor runs along the bottom face of the beam. Two physical parameters:

- ``E``: Young's modulus [GPa] of the concrete (beam and columns);
- ``log10_k_j``: log10 of the joints' rotational stiffness [N·m/rad]: about 6 is a pin,
  about 10 a rigid joint (the beam's own 4 E I / L is about 8e7 N·m/rad).

The output is the bottom-fibre strain [µε] of the beam, ``N / (E A) + M (h / 2) / (E I)``
(M sagging positive), at the sensor positions ``x`` for every load case (a 100 kN point load
at position ``load`` [m] along the beam), all at once.

OpenSees keeps one model per process in global state, so each call starts with ``wipe()`` and
builds the model again for every load case: a call gives the same answer whatever ran before
in that process, and calls in different worker processes (``executor=joblib``) are independent.
"""

from __future__ import annotations

import hashlib

import numpy as np
import torch
from torch import Tensor

HEIGHT, SPAN, ELEMENT = 4.0, 8.0, 0.1  # m
BEAM = (0.3, 0.6)  # width, depth [m]
COLUMN = (0.4, 0.4)
LOAD = 100e3  # N


class PortalFrame:
    """Forward model ``model(theta_p `... x 2`) -> strains `... x L x n` [µε]``.

    Args:
        loads: positions [m] of the point load along the beam, each a multiple of 0.1 m.
        pitch: spacing of the sensor positions ``x`` along the beam [m], a multiple of 0.1 m.
    """

    names = ("E", "log10_k_j")
    units = {"E": "GPa", "log10_k_j": "log10 N·m/rad"}

    def __init__(self, loads: tuple[float, ...] = (1.6, 3.2, 4.8, 6.4), pitch: float = 0.1) -> None:
        self.loads = torch.tensor(loads, dtype=torch.float64)
        n_el = round(SPAN / ELEMENT)
        step = round(pitch / ELEMENT)
        if abs(step * ELEMENT - pitch) > 1e-9 or step < 1:
            raise ValueError(f"pitch {pitch} m must be a multiple of the element length {ELEMENT} m")
        self._load_nodes = [round(a / ELEMENT) for a in loads]
        if any(abs(i * ELEMENT - a) > 1e-9 or not 0 < i < n_el for i, a in zip(self._load_nodes, loads)):
            raise ValueError(f"load positions {list(loads)} must be multiples of {ELEMENT} m inside the beam")
        self._sensors = np.arange(0, n_el + 1, step)
        self.x = torch.tensor(self._sensors * ELEMENT, dtype=torch.float64)
        key = repr((loads, pitch, HEIGHT, SPAN, ELEMENT, BEAM, COLUMN, LOAD)).encode()
        self.identity = f"PortalFrame-{hashlib.sha256(key).hexdigest()[:16]}"

    def __repr__(self) -> str:
        return f"PortalFrame(L={len(self.loads)}, n={len(self.x)})"

    def __call__(self, theta_p: Tensor) -> Tensor:
        theta = torch.as_tensor(theta_p, dtype=torch.float64)
        if theta.ndim == 0 or theta.shape[-1] != 2:
            raise ValueError(f"theta_p must end in 2 (E, log10_k_j), got shape {tuple(theta.shape)}")
        rows = theta.reshape(-1, 2).tolist()
        out = [[self._strain(e, k, node) for node in self._load_nodes] for e, k in rows]
        strains = torch.tensor(np.asarray(out), dtype=torch.float64).reshape(-1, len(self.loads), len(self.x))
        return strains.reshape(*theta.shape[:-1], len(self.loads), len(self.x))

    def _strain(self, e_gpa: float, log10_k: float, load_node: int) -> np.ndarray:
        """Bottom-fibre strain [µε] at the sensors for the load at beam node ``load_node``."""
        import openseespy.opensees as ops

        e, n_el = e_gpa * 1e9, round(SPAN / ELEMENT)
        ops.wipe()
        ops.model("basic", "-ndm", 2, "-ndf", 3)
        for i in range(n_el + 1):  # beam nodes 1 .. n_el + 1
            ops.node(1 + i, i * ELEMENT, HEIGHT)
        base, top = 1000, 2000  # column nodes: bases 1000/1001, tops 2000/2001
        for side, xc in enumerate((0.0, SPAN)):
            ops.node(base + side, xc, 0.0)
            ops.node(top + side, xc, HEIGHT)
            ops.fix(base + side, 1, 1, 1)
        ops.geomTransf("Linear", 1)
        area, inertia = BEAM[0] * BEAM[1], BEAM[0] * BEAM[1] ** 3 / 12
        for i in range(n_el):
            ops.element("elasticBeamColumn", 1 + i, 1 + i, 2 + i, area, e, inertia, 1)
        col_area, col_inertia = COLUMN[0] * COLUMN[1], COLUMN[0] * COLUMN[1] ** 3 / 12
        ops.uniaxialMaterial("Elastic", 1, 10.0**log10_k)
        for side, beam_end in enumerate((1, n_el + 1)):
            ops.element("elasticBeamColumn", 500 + side, base + side, top + side, col_area, e, col_inertia, 1)
            ops.element("zeroLength", 600 + side, top + side, beam_end, "-mat", 1, "-dir", 3)
            ops.equalDOF(top + side, beam_end, 1, 2)
        ops.timeSeries("Constant", 1)
        ops.pattern("Plain", 1, 1)
        ops.load(1 + load_node, 0.0, -LOAD, 0.0)
        ops.system("BandGeneral")
        ops.numberer("RCM")
        ops.constraints("Transformation")
        ops.integrator("LoadControl", 1.0)
        ops.algorithm("Linear")
        ops.analysis("Static")
        if ops.analyze(1) != 0:
            raise RuntimeError(f"OpenSees analysis failed at E={e_gpa} GPa, log10_k_j={log10_k}")
        # internal forces at each beam node from the element to its right (the last: its left)
        forces = np.array([ops.eleResponse(1 + i, "localForce") for i in range(n_el)])
        axial = np.append(-forces[:, 0], forces[-1, 3])  # tension positive
        moment = np.append(-forces[:, 2], forces[-1, 5])  # sagging positive
        ops.wipe()
        strain = axial / (e * area) + moment * (BEAM[1] / 2) / (e * inertia)
        return 1e6 * strain[self._sensors]

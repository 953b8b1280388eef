"""Cheap forward models of the identification suite: a batched beam and an orthotropic plate.

:class:`Beam` is an Euler-Bernoulli beam on point supports (rigid or vertical springs, with
optional rotational springs), finite elements of equal length, assembled and solved for a whole
batch of parameter vectors at once. Each physical parameter has a *role* (below), so one class
serves every beam of the suite. :class:`OrthotropicPlate` is a simply supported rectangular
plate under patch loads, solved by Navier's double sine series, its strain read on a grid of
image-correlation points (`n x 2` coordinates).

Both follow :class:`torchshm.forward.protocol.ForwardModel`: ``model(theta_p `... x P`)`` returns
strains `... x L x n` [µε], with attributes ``x``, ``loads``, ``names`` and ``identity``.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field

import torch
from torch import Tensor

#: the truck of every beam load case: (offset behind the front axle [m], axle load [N])
AXLES = ((0.0, 100e3), (4.0, 150e3))


@dataclass(frozen=True)
class Role:
    """What one physical parameter does to a :class:`Beam`.

    kind: ``"modulus"`` (EI factor [GPa] on elements within ``span``), ``"factor"`` (dimensionless
    EI factor within ``span``), ``"log10_rot"`` / ``"log10_vert"`` (log10 of a rotational
    [N·m/rad] or vertical [N/m] spring at support ``support``), ``"depth"`` (fibre distance
    below the neutral axis [m]), ``"damage_pos"`` [m] (centre of a Gaussian loss of stiffness of
    width ``width`` [m] and relative depth ``depth``, or, when ``depth`` is 0, of the
    ``"damage_depth"`` parameter, 0..1).
    """

    kind: str
    span: tuple[float, float] = (-math.inf, math.inf)
    support: int = 0
    width: float = 1.0
    depth: float = 0.0


@dataclass
class BeamSpec:
    """Geometry of a :class:`Beam`: supports [m], element length [m], sensors, load cases.

    ``lines`` maps a fibre label to its distance from the neutral axis [m] (positive below);
    a role ``"depth"`` overrides the first line's. ``point_loads``: single 100 kN loads at the
    load positions instead of the truck.
    """

    supports: tuple[float, ...]
    element: float
    sensors: tuple[float, float, float]  # first, last, pitch [m]
    loads: tuple[float, ...]
    inertia: float = 0.08
    lines: dict[str, float] = field(default_factory=lambda: {"bottom": 0.6})
    point_loads: bool = False
    fixed_rot: tuple[tuple[int, float], ...] = ()  # (support, log10 N·m/rad) of known springs


class Beam:
    """Batched beam ``model(theta_p `... x P`) -> strains `... x L x n` [µε] (see module doc)."""

    def __init__(self, spec: BeamSpec, roles: dict[str, Role], name: str) -> None:
        self.spec, self.roles, self.names = spec, roles, tuple(roles)
        length = spec.supports[-1] - spec.supports[0]
        n_el = round(length / spec.element)
        self.h = length / n_el
        self.nodes = spec.supports[0] + self.h * torch.arange(n_el + 1, dtype=torch.float64)
        self.centres = self.nodes[:-1] + self.h / 2
        first, last, pitch = spec.sensors
        pos = torch.round(torch.arange(first, last + pitch / 2, pitch, dtype=torch.float64) * 1e6) / 1e6
        labels = list(spec.lines)
        self.x = pos.repeat(len(labels))
        if len(labels) > 1:
            self.line = [lab for lab in labels for _ in range(len(pos))]
        self._depth = torch.tensor([spec.lines[lab] for lab in labels], dtype=torch.float64)
        self.loads = torch.as_tensor(spec.loads, dtype=torch.float64)
        self._support_nodes = [round((s - spec.supports[0]) / self.h) for s in spec.supports]
        vert = {r.support for r in roles.values() if r.kind == "log10_vert"}
        fixed = {2 * self._support_nodes[i] for i in range(len(spec.supports)) if i not in vert}
        self._free = [d for d in range(2 * (n_el + 1)) if d not in fixed]
        self._ke, self._idx = self._element_matrices(n_el)
        self._force = self._load_vectors()[self._free]
        self._curv = self._curvature(pos)
        key = f"{name}-{spec}-{sorted((k, str(v)) for k, v in roles.items())}"
        self.identity = f"{name}-{hashlib.sha256(key.encode()).hexdigest()[:12]}"

    def __call__(self, theta_p: object) -> Tensor:
        """Strains `... x L x n` [µε] (all lines, in ``x`` order) for `... x P` parameters."""
        theta = torch.as_tensor(theta_p, dtype=torch.float64)
        flat = theta.reshape(-1, len(self.names))
        b, ndof = flat.shape[0], 2 * len(self.nodes)
        ei = 1e9 * self.spec.inertia * torch.ones(b, len(self.centres), dtype=torch.float64)
        depth = self._depth.expand(b, -1).clone()
        diag = torch.zeros(b, ndof, dtype=torch.float64)
        for support, log10_k in self.spec.fixed_rot:
            diag[:, 2 * self._support_nodes[support] + 1] += 10.0 ** log10_k
        for j, role in enumerate(self.roles.values()):
            v = flat[:, j]
            inside = ((self.centres >= role.span[0]) & (self.centres <= role.span[1])).to(v.dtype)
            if role.kind in ("modulus", "factor"):
                ei = ei * (1 + (v[:, None] - 1) * inside)
            elif role.kind == "log10_rot":
                diag[:, 2 * self._support_nodes[role.support] + 1] += 10.0 ** v
            elif role.kind == "log10_vert":
                diag[:, 2 * self._support_nodes[role.support]] += 10.0 ** v
            elif role.kind == "depth":
                depth[:, 0] = v
        ei = ei * self._damage(flat)
        k = torch.zeros(b, ndof * ndof, dtype=torch.float64)
        k.index_add_(1, self._idx, (ei[:, :, None] * self._ke).reshape(b, -1))
        k = k.reshape(b, ndof, ndof) + torch.diag_embed(diag)
        kf = k[:, self._free][:, :, self._free]
        u = torch.zeros(b, ndof, len(self.loads), dtype=torch.float64)
        u[:, self._free] = torch.linalg.solve(kf, self._force.expand(b, -1, -1))
        curv = (self._curv @ u).transpose(-1, -2)  # B x L x n_pos: w'' [1/m]
        out = 1e6 * depth[:, None, :, None] * curv[:, :, None, :]  # B x L x lines x n_pos
        return out.reshape(*theta.shape[:-1], len(self.loads), len(self.x))

    def _damage(self, flat: Tensor) -> Tensor:
        """EI factors `B x n_el` of the Gaussian damages (1 without one): one per ``damage_pos``
        role, of the role's fixed ``depth`` or, when that is 0, of the ``damage_depth`` parameter."""
        factor = torch.ones(1, len(self.centres), dtype=torch.float64)
        roles = list(self.roles.values())
        free = [j for j, r in enumerate(roles) if r.kind == "damage_depth"]
        for j, role in enumerate(roles):
            if role.kind == "damage_pos":
                dep = flat[:, free[0], None] if role.depth == 0.0 else role.depth
                factor = factor * (1 - dep * torch.exp(-0.5 * ((self.centres - flat[:, j, None]) / role.width) ** 2))
        return factor

    def _element_matrices(self, n_el: int) -> tuple[Tensor, Tensor]:
        """Unit element stiffness `n_el x 16` and its flat global indices `n_el * 16`."""
        h, ndof = self.h, 2 * (n_el + 1)
        ke = torch.tensor([[12, 6 * h, -12, 6 * h], [6 * h, 4 * h * h, -6 * h, 2 * h * h],
                           [-12, -6 * h, 12, -6 * h], [6 * h, 2 * h * h, -6 * h, 4 * h * h]],
                          dtype=torch.float64) / h**3
        dofs = 2 * torch.arange(n_el)[:, None] + torch.arange(4)[None, :]  # n_el x 4
        idx = (dofs[:, :, None] * ndof + dofs[:, None, :]).reshape(-1)
        return ke.reshape(1, 16).expand(n_el, 16), idx

    def _shape(self, pos: float) -> tuple[int, float]:
        e = min(max(int((pos - float(self.nodes[0])) // self.h), 0), len(self.centres) - 1)
        return e, (pos - float(self.nodes[e])) / self.h

    def _load_vectors(self) -> Tensor:
        """Consistent nodal forces `2(N+1) x L` [N] (downwards) of each load case."""
        f = torch.zeros(2 * len(self.nodes), len(self.loads), dtype=torch.float64)
        axles = ((0.0, 100e3),) if self.spec.point_loads else AXLES
        for j, front in enumerate(self.loads.tolist()):
            for offset, weight in axles:
                p = front - offset
                if not float(self.nodes[0]) <= p <= float(self.nodes[-1]):
                    continue
                e, s = self._shape(p)
                n = [1 - 3 * s**2 + 2 * s**3, self.h * (s - 2 * s**2 + s**3), 3 * s**2 - 2 * s**3,
                     self.h * (s**3 - s**2)]
                f[2 * e: 2 * e + 4, j] -= weight * torch.tensor(n, dtype=torch.float64)
        return f

    def _curvature(self, pos: Tensor) -> Tensor:
        """`n_pos x 2(N+1)`: w'' [1/m] at the sensor positions from the nodal DOFs."""
        b = torch.zeros(len(pos), 2 * len(self.nodes), dtype=torch.float64)
        h = self.h
        for i, p in enumerate(pos.tolist()):
            e, s = self._shape(p)
            b[i, 2 * e: 2 * e + 4] = torch.tensor(
                [(-6 + 12 * s) / h**2, (-4 + 6 * s) / h, (6 - 12 * s) / h**2, (-2 + 6 * s) / h],
                dtype=torch.float64)
        return b


class OrthotropicPlate:
    """Simply supported `a x b` plate, thickness ``t``, under square patch loads (Navier series).

    Parameters ``E_x``, ``E_y`` [GPa] (moduli along x and y; torsional rigidity
    ``H = sqrt(D_x D_y)``). Load cases: patch centres' x [m] on ``y = b / 2``. Output: bottom
    strain ``eps_xx`` [µε] at a `g_x x g_y` grid of points ``x`` `(n, 2)` [m].
    """

    names = ("E_x", "E_y")

    def __init__(self, size: tuple[float, float] = (3.0, 2.0), thickness: float = 0.15,
                 grid: tuple[int, int] = (16, 12), loads: tuple[float, ...] = (1.0, 2.0),
                 patch: float = 0.4, force: float = 60e3, terms: int = 25) -> None:
        a, b = size
        self.t = thickness
        gx = (torch.arange(grid[0], dtype=torch.float64) + 0.5) * a / grid[0]
        gy = (torch.arange(grid[1], dtype=torch.float64) + 0.5) * b / grid[1]
        px, py = torch.meshgrid(gx, gy, indexing="ij")
        self.x = torch.stack([px.reshape(-1), py.reshape(-1)], 1)
        self.loads = torch.as_tensor(loads, dtype=torch.float64)
        m = torch.arange(1, terms + 1, dtype=torch.float64)
        self._am, self._bn = m * math.pi / a, m * math.pi / b  # terms
        q = force / patch**2
        c = patch / 2
        # patch load coefficients q_mn = 16 q / (π² m n) sin(αm x0) sin(βn y0) sin(αm c) sin(βn c)
        qm = torch.sin(self._am[None, :] * self.loads[:, None]) * torch.sin(self._am * c)  # L x M
        qn = torch.sin(self._bn * b / 2) * torch.sin(self._bn * c)  # N
        self._q = 16 * q / math.pi**2 * qm[:, :, None] * qn[None, None, :] / (m[:, None] * m[None, :])
        self._sx = torch.sin(self._am[None, :] * self.x[:, :1])  # n x M
        self._sy = torch.sin(self._bn[None, :] * self.x[:, 1:])  # n x N
        self.identity = f"OrthotropicPlate-{size}-{thickness}-{grid}-{tuple(loads)}-{patch}-{force}-{terms}"

    def __call__(self, theta_p: object) -> Tensor:
        """Strains `... x L x n` [µε] for ``(E_x, E_y)`` `... x 2` [GPa]."""
        theta = torch.as_tensor(theta_p, dtype=torch.float64)
        flat = theta.reshape(-1, 2)
        d = 1e9 * self.t**3 / 12.0
        dx, dy = d * flat[:, 0], d * flat[:, 1]
        a4, b4 = self._am[:, None] ** 4, self._bn[None, :] ** 4
        a2b2 = self._am[:, None] ** 2 * self._bn[None, :] ** 2
        den = dx[:, None, None] * a4 + 2 * torch.sqrt(dx * dy)[:, None, None] * a2b2 + dy[:, None, None] * b4
        w = self._q[None] / den[:, None]  # B x L x M x N
        coef = w * self._am[:, None] ** 2 * (self.t / 2) * 1e6  # eps_xx = (t/2) Σ α² w_mn sin sin
        out = torch.einsum("blmn,pm,pn->blp", coef, self._sx, self._sy)
        return out.reshape(*theta.shape[:-1], len(self.loads), self.x.shape[0])

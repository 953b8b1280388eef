"""A rectangular slab under a patch load, seen by image correlation: the 2-D example's model.

A Kirchhoff plate ``a x b`` (x along ``a``), thickness ``t``, uniform flexural rigidity
``D = E t³ / (12 (1 - nu²))``, loaded by a uniform square patch (the load case is the patch
centre's x [m], on the line ``y = b / 2``). The edges ``y = 0`` and ``y = b`` are simply
supported; the edges ``x = 0`` and ``x = a`` rest on a support with a rotational spring of
stiffness ``k`` [N·m/rad per m of edge]: ``D w_xx = k w_x`` at ``x = 0`` (``k = 0`` a simple
support, ``k -> inf`` a clamp). Two physical parameters:

- ``E``: Young's modulus [GPa];
- ``log10_k``: log10 of the edge rotational stiffness ``k`` [N·m/rad/m].

Finite differences on a square grid of pitch ``h`` (deflection ``w`` positive downwards, along
the load): ``D ∇⁴w = q`` with the 13-point stencil, ``w = 0`` on the edges and ghost nodes
``w_-1 = -w_1`` on the simple supports, ``w_-1 = r w_1``, ``r = (β - 1)/(β + 1)``,
``β = k h / (2 D)`` on the springs. The stencil matrix is then::

    A(r) = (Lx ⊗ I + I ⊗ Ly)² + (1 + r) U Uᵀ

with ``Lx``, ``Ly`` the Dirichlet second differences and ``U`` the columns of the nodes next to
the spring edges; ``(h⁴ / D)`` times the solution of ``A w = q`` is the deflection. The spring
term has rank ``2 (ny - 1)``, so one factorisation of ``A(-1)`` (the simply supported plate) made
once, and a small ``2 (ny - 1)`` system per parameter vector (Woodbury's identity) give every
load case's field. The output is the bottom-surface strain ``eps_xx = -(t/2) w_xx`` [µε] at the
image-correlation points ``x`` `(n, 2)`, every load case at once.
"""

from __future__ import annotations

import hashlib

import torch
from torch import Tensor


def second_difference(m: int) -> Tensor:
    """`m x m` Dirichlet second difference ``tridiag(1, -2, 1)`` (unit pitch)."""
    return -2.0 * torch.eye(m, dtype=torch.float64) + torch.diag(torch.ones(m - 1, dtype=torch.float64), 1) \
        + torch.diag(torch.ones(m - 1, dtype=torch.float64), -1)


class PlateDIC:
    """Forward model ``model(theta_p `... x 2`) -> strains `... x L x n` [µε]``.

    Args:
        size: plate dimensions ``(a, b)`` [m].
        thickness: slab thickness ``t`` [m].
        poisson: Poisson's ratio ``nu``.
        cell: finite-difference pitch ``h`` [m]; must divide ``a``, ``b``, ``pitch`` and ``patch``.
        pitch: spacing of the image-correlation points [m], a whole multiple of ``cell``; the
            points are the interior grid nodes from ``cell`` away from the edges.
        patch: side of the square loaded patch [m]; force: its total load [N].
        loads: patch-centre x positions [m] of the load cases (on ``y = b / 2``).
    """

    names = ("E", "log10_k")
    units = {"E": "GPa", "log10_k": "log10 N·m/rad/m"}

    def __init__(
        self,
        size: tuple[float, float] = (2.0, 1.5),
        thickness: float = 0.12,
        poisson: float = 0.2,
        cell: float = 0.0625,
        pitch: float = 0.125,
        patch: float = 0.25,
        force: float = 50e3,
        loads: tuple[float, ...] = (0.5, 0.75, 1.0, 1.25, 1.5),
    ) -> None:
        a, b = (float(s) for s in size)
        nx, ny, step = round(a / cell), round(b / cell), round(pitch / cell)
        for name, v in (("size a", a), ("size b", b), ("pitch", pitch)):
            if abs(v / cell - round(v / cell)) > 1e-9 or round(v / cell) < 1:
                raise ValueError(f"PlateDIC: cell {cell} m must divide {name} = {v} m")
        self.h, self.t, self.size = float(cell), float(thickness), (a, b)
        self.rigidity_per_gpa = 1e9 * self.t**3 / (12.0 * (1.0 - poisson**2))  # D / E [N·m per GPa]
        self.loads = torch.as_tensor(loads, dtype=torch.float64)
        lx, ly = second_difference(nx - 1), second_difference(ny - 1)
        eye_x, eye_y = torch.eye(nx - 1, dtype=torch.float64), torch.eye(ny - 1, dtype=torch.float64)
        laplace = torch.kron(lx, eye_y) + torch.kron(eye_x, ly)  # node (i, j) -> (i - 1)(ny - 1) + j - 1
        edge = torch.tensor([0, nx - 2])  # grid columns next to x = 0 and x = a
        self._u = torch.kron(torch.eye(nx - 1, dtype=torch.float64)[:, edge], eye_y)  # N x 2(ny - 1)
        chol = torch.linalg.cholesky(laplace @ laplace)  # A(-1): the simply supported plate
        gi, gj = torch.meshgrid(torch.arange(1, nx), torch.arange(1, ny), indexing="ij")
        keep = ((gi % step == 1 % step) & (gj % step == 1 % step)).reshape(-1)  # points from h inward
        self.x = torch.stack([gi.reshape(-1)[keep] * cell, gj.reshape(-1)[keep] * cell], dim=1).to(torch.float64)
        self.x = torch.round(self.x * 1e9) / 1e9
        strain = -0.5 * self.t / cell**2 * torch.kron(lx, eye_y)[keep]  # n x N: w -> eps_xx [-]
        w0 = torch.cholesky_solve(self._load_vectors(gi, gj, patch, force), chol)  # N x L
        g = torch.cholesky_solve(self._u, chol)  # N x 2(ny - 1)
        self._cap = self._u.T @ g  # Uᵀ A⁻¹ U
        self._uw0 = self._u.T @ w0
        self._sw0, self._sg = strain @ w0, strain @ g
        self._w0, self._g = w0, g  # for :meth:`deflections`
        key = f"{size}-{thickness}-{poisson}-{cell}-{pitch}-{patch}-{force}-{tuple(loads)}"
        self.identity = f"PlateDIC-{hashlib.sha256(key.encode()).hexdigest()[:12]}"

    def __call__(self, theta_p: object) -> Tensor:
        """Bottom-surface strains ``eps_xx`` `... x L x n` [µε] for ``(E, log10_k)`` `... x 2`."""
        theta = torch.as_tensor(theta_p, dtype=torch.float64)
        if theta.shape[-1:] != (2,):
            raise ValueError(f"PlateDIC: theta_p must end in 2 parameters {self.names}, got {tuple(theta.shape)}")
        flat = theta.reshape(-1, 2)
        out = self.strains(flat[:, 0], 10.0 ** flat[:, 1])
        return out.reshape(*theta.shape[:-1], len(self.loads), self.x.shape[0])

    def strains(self, e_gpa: Tensor, k: Tensor) -> Tensor:
        """Strains `B x L x n` [µε] for moduli `B` [GPa] and edge stiffnesses `B` [N·m/rad/m] (0 allowed)."""
        rigidity, z = self._edge_solution(e_gpa, k)
        eps = self._sw0 - self._sg @ z  # B x n x L, for D = 1 and h⁴ folded in below
        return (1e6 * self.h**4 / rigidity)[:, None, None] * eps.transpose(-1, -2)

    def deflections(self, e_gpa: Tensor, k: Tensor) -> Tensor:
        """Deflections `B x L x N` [m] at the interior nodes (node ``(i, j)``, ``i = 1 .. nx - 1``,
        ``j = 1 .. ny - 1``, at ``(i - 1)(ny - 1) + j - 1``); 0 on the edges."""
        rigidity, z = self._edge_solution(e_gpa, k)
        w = self._w0 - self._g @ z  # B x N x L
        return (self.h**4 / rigidity)[:, None, None] * w.transpose(-1, -2)

    def _edge_solution(self, e_gpa: Tensor, k: Tensor) -> tuple[Tensor, Tensor]:
        """Rigidities `B` [N·m] and the edge moments' unknowns `B x 2(ny - 1) x L`."""
        rigidity = e_gpa * self.rigidity_per_gpa  # D [N·m]
        beta = k * self.h / (2.0 * rigidity)
        c = 2.0 * beta / (beta + 1.0)  # 1 + r: 0 for a simple support, 2 for a clamp
        eye = torch.eye(self._cap.shape[0], dtype=torch.float64)
        small = eye + c[:, None, None] * self._cap  # B x 2(ny-1) x 2(ny-1)
        return rigidity, torch.linalg.solve(small, c[:, None, None] * self._uw0)  # (I + c C)⁻¹ c Uᵀ w0

    def _load_vectors(self, gi: Tensor, gj: Tensor, patch: float, force: float) -> Tensor:
        """Nodal loads `N x L` [N/m²]: the patch pressure averaged over each node's `h x h` cell."""
        h, b = self.h, self.size[1]
        x, y = gi.reshape(-1, 1) * h, gj.reshape(-1, 1) * h

        def overlap(node: Tensor, centre: Tensor) -> Tensor:
            lo = torch.maximum(node - h / 2, centre - patch / 2)
            hi = torch.minimum(node + h / 2, centre + patch / 2)
            return (hi - lo).clamp_min(0.0)

        share = overlap(x, self.loads[None, :]) * overlap(y, torch.tensor(b / 2, dtype=torch.float64))
        return force / patch**2 * share / h**2

    def __repr__(self) -> str:
        return f"PlateDIC(n={self.x.shape[0]}, loads={len(self.loads)})"

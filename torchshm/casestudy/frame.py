"""Linear 2-D Euler–Bernoulli frames: assembly, solve and bottom-fibre strain recovery.

A frame is a set of nodes in the vertical plane (x along the bridge, z upwards), straight
two-node elements with axial stiffness EA and bending stiffness EI, constrained degrees of
freedom and grounded springs. Every node carries three degrees of freedom, numbered
``3 * node + c`` with ``c = 0`` the horizontal displacement u, ``c = 1`` the vertical
displacement w (upwards) and ``c = 2`` the rotation θ (counter-clockwise).

Units are consistent N and mm throughout: coordinates in mm, EA in N, EI in N·mm², forces in N,
springs in N/mm or N·mm/rad, displacements in mm and rad.

With nodal loads only, the Hermite (cubic) element is exact: nodal displacements are exact and
inside an element the bending moment is linear between its end values. The strain of the
bottom fibre, a distance ``c_b`` below the element axis, follows from the element's own
displacements, ``ε = du/ds + c_b · d²w/ds²`` (local coordinates, s along the element), which
equals ``N / EA + M · c_b / EI`` with M the sagging moment; it is recovered by a linear
operator on the displacements that does not depend on the stiffness.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import torch
from torch import Tensor

#: degrees of freedom per node
NDOF = 3


def dof(node: int | Tensor, component: int) -> int | Tensor:
    """Global index of ``component`` (0: u, 1: w, 2: θ) of ``node``."""
    return NDOF * node + component


@dataclass
class Frame:
    """A 2-D frame.

    Attributes:
        nodes: `N x 2` node coordinates (x, z) [mm].
        elements: `M x 2` node indices (start, end) of each element, int64.
        EA: `M` axial stiffness of each element [N].
        EI: `M` bending stiffness of each element [N·mm²].
        fixed: indices of the constrained (zero) degrees of freedom, int64.
        spring_dofs: indices of degrees of freedom with a grounded spring, int64.
        spring_stiffness: stiffness of each of those springs [N/mm or N·mm/rad].
    """

    nodes: Tensor
    elements: Tensor
    EA: Tensor
    EI: Tensor
    fixed: Tensor
    spring_dofs: Tensor = field(default_factory=lambda: torch.zeros(0, dtype=torch.int64))
    spring_stiffness: Tensor = field(default_factory=lambda: torch.zeros(0, dtype=torch.float64))

    @property
    def n_dof(self) -> int:
        """Total number of degrees of freedom (constrained ones included)."""
        return NDOF * self.nodes.shape[0]

    @property
    def free(self) -> Tensor:
        """Indices of the unconstrained degrees of freedom, ascending."""
        mask = torch.ones(self.n_dof, dtype=torch.bool)
        mask[self.fixed] = False
        return torch.nonzero(mask).squeeze(-1)

    def geometry(self) -> tuple[Tensor, Tensor, Tensor]:
        """Length [mm], direction cosine and direction sine of each element (`M` each)."""
        delta = self.nodes[self.elements[:, 1]] - self.nodes[self.elements[:, 0]]
        length = torch.linalg.vector_norm(delta, dim=-1)
        return length, delta[:, 0] / length, delta[:, 1] / length

    def element_dofs(self) -> Tensor:
        """`M x 6` global degree-of-freedom indices of each element (start node, then end)."""
        first, second = self.elements[:, :1] * NDOF, self.elements[:, 1:] * NDOF
        offsets = torch.arange(NDOF)
        return torch.cat([first + offsets, second + offsets], dim=1)


def rotation(cos: Tensor, sin: Tensor) -> Tensor:
    """`M x 6 x 6` transformations from global to local element degrees of freedom."""
    T = torch.zeros(cos.shape[0], 6, 6, dtype=torch.float64)
    for block in (0, 3):
        T[:, block, block], T[:, block, block + 1] = cos, sin
        T[:, block + 1, block], T[:, block + 1, block + 1] = -sin, cos
        T[:, block + 2, block + 2] = 1.0
    return T


def local_stiffness(length: Tensor, EA: Tensor, EI: Tensor) -> Tensor:
    """`M x 6 x 6` local stiffness matrices of Euler–Bernoulli frame elements (N, mm)."""
    k = torch.zeros(length.shape[0], 6, 6, dtype=torch.float64)
    a = EA / length
    b12, b6, b4, b2 = 12 * EI / length**3, 6 * EI / length**2, 4 * EI / length, 2 * EI / length
    k[:, 0, 0], k[:, 3, 3], k[:, 0, 3], k[:, 3, 0] = a, a, -a, -a
    k[:, 1, 1], k[:, 4, 4], k[:, 1, 4], k[:, 4, 1] = b12, b12, -b12, -b12
    k[:, 1, 2], k[:, 2, 1], k[:, 1, 5], k[:, 5, 1] = b6, b6, b6, b6
    k[:, 4, 2], k[:, 2, 4], k[:, 4, 5], k[:, 5, 4] = -b6, -b6, -b6, -b6
    k[:, 2, 2], k[:, 5, 5], k[:, 2, 5], k[:, 5, 2] = b4, b4, b2, b2
    return k


def stiffness(frame: Frame) -> Tensor:
    """Dense global stiffness matrix `n_dof x n_dof`, springs included, supports not applied."""
    length, cos, sin = frame.geometry()
    T = rotation(cos, sin)
    k_global = T.transpose(1, 2) @ local_stiffness(length, frame.EA, frame.EI) @ T
    index = frame.element_dofs()
    rows = index[:, :, None].expand(-1, 6, 6).reshape(-1)
    cols = index[:, None, :].expand(-1, 6, 6).reshape(-1)
    K = torch.zeros(frame.n_dof, frame.n_dof, dtype=torch.float64)
    K.index_put_((rows, cols), k_global.reshape(-1), accumulate=True)
    diag = frame.spring_dofs
    K.index_put_((diag, diag), frame.spring_stiffness.to(torch.float64), accumulate=True)
    return K


def reduced_stiffness(frame: Frame) -> Tensor:
    """Stiffness matrix restricted to the free degrees of freedom (`n_free x n_free`)."""
    free = frame.free
    return stiffness(frame)[free][:, free]


def solve(frame: Frame, loads: Tensor) -> Tensor:
    """Displacements of a frame under nodal loads.

    Args:
        frame: the frame; its reduced stiffness must be positive definite (a stable structure).
        loads: `n_dof x k` nodal forces [N, N·mm] for k load cases (entries at constrained
            degrees of freedom are reactions and are ignored).

    Returns:
        `n_dof x k` displacements [mm, rad], zero at the constrained degrees of freedom.
    """
    free = frame.free
    factor = torch.linalg.cholesky(reduced_stiffness(frame))
    U = torch.zeros(frame.n_dof, loads.shape[1], dtype=torch.float64)
    U[free] = torch.cholesky_solve(loads[free], factor)
    return U


def end_forces(frame: Frame, U: Tensor) -> Tensor:
    """Local end forces `k x M x 6` (N, V, M at start; N, V, M at end) for displacements `U`.

    Sign convention of the element's own stiffness: forces acting on the element, positive
    along the local axes. The sagging bending moment is ``-f[..., 2]`` at the start and
    ``f[..., 5]`` at the end; the tensile axial force is ``-f[..., 0]``.
    """
    length, cos, sin = frame.geometry()
    T = rotation(cos, sin)
    u_local = T @ U[frame.element_dofs()]  # M x 6 x k
    f = local_stiffness(length, frame.EA, frame.EI) @ u_local
    return f.permute(2, 0, 1)


def _strain_rows(frame: Frame, element: Tensor, xi: Tensor, c_b: Tensor) -> Tensor:
    """`P x 6` bottom-fibre strain rows on the global dofs of each point's element."""
    length, cos, sin = frame.geometry()
    L = length[element]
    T = rotation(cos[element], sin[element])
    # du/ds and c_b * d²w/ds² of the Hermite interpolation, on local dofs
    row = torch.zeros(element.shape[0], 6, dtype=torch.float64)
    row[:, 0], row[:, 3] = -1.0 / L, 1.0 / L
    scale = c_b / L**2
    row[:, 1] = scale * (-6.0 + 12.0 * xi)
    row[:, 2] = scale * L * (-4.0 + 6.0 * xi)
    row[:, 4] = scale * (6.0 - 12.0 * xi)
    row[:, 5] = scale * L * (-2.0 + 6.0 * xi)
    return (row[:, None, :] @ T).squeeze(1)


def bottom_strain_operator(frame: Frame, element: Tensor, xi: Tensor, c_b: Tensor) -> Tensor:
    """Linear operator from displacements to the bottom-fibre strain at points in elements.

    Args:
        frame: the frame.
        element: `P` index of the element holding each point.
        xi: `P` local coordinate of each point, 0 at the element's start node, 1 at its end.
        c_b: `P` distance from the element axis to the bottom fibre [mm] (on the element's
            right-hand side when looking from start to end node, i.e. below a deck element
            that runs in +x).

    Returns:
        `P x n_dof` matrix B; ``B @ U`` is the strain (dimensionless, tension positive).
    """
    rows = _strain_rows(frame, element, xi, c_b)
    B = torch.zeros(element.shape[0], frame.n_dof, dtype=torch.float64)
    B.scatter_add_(1, frame.element_dofs()[element], rows)
    return B


def bottom_strain(frame: Frame, U: Tensor, element: Tensor, xi: Tensor, c_b: Tensor) -> Tensor:
    """Bottom-fibre strains `P x k` for displacements `U` (`n_dof x k`), without forming B.

    Arguments as in :func:`bottom_strain_operator`.
    """
    rows = _strain_rows(frame, element, xi, c_b)
    return torch.einsum("pd,pdk->pk", rows, U[frame.element_dofs()[element]])

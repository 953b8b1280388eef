"""The frame solver against closed-form Euler–Bernoulli results."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from torchshm.casestudy.frame import Frame, bottom_strain, bottom_strain_operator, dof, end_forces, solve, stiffness

E = 35_000.0  # N/mm²
WIDTH, DEPTH = 1000.0, 500.0  # mm
AREA, INERTIA, C_B = WIDTH * DEPTH, WIDTH * DEPTH**3 / 12.0, DEPTH / 2.0
P = 100_000.0  # N


def beam(x_mm: np.ndarray, supports: list[int]) -> Frame:
    """A horizontal beam through `x_mm`, pinned at its first support, rollers at the others."""
    n = x_mm.size
    fixed = [dof(supports[0], 0)] + [dof(s, 1) for s in supports]
    return Frame(
        nodes=torch.as_tensor(np.column_stack([x_mm, np.zeros(n)]), dtype=torch.float64),
        elements=torch.as_tensor(np.column_stack([np.arange(n - 1), np.arange(1, n)])),
        EA=torch.full((n - 1,), E * AREA, dtype=torch.float64),
        EI=torch.full((n - 1,), E * INERTIA, dtype=torch.float64),
        fixed=torch.tensor(sorted(fixed)),
    )


def point_load(frame: Frame, node: int, force: float = P, component: int = 1) -> torch.Tensor:
    F = torch.zeros(frame.n_dof, 1, dtype=torch.float64)
    F[dof(node, component), 0] = -force if component == 1 else force
    return F


def strain_at(frame: Frame, U: torch.Tensor, element: int, xi: float) -> float:
    B = bottom_strain_operator(frame, torch.tensor([element]), torch.tensor([xi]), torch.tensor([C_B]))
    return float((B @ U)[0, 0])


def test_simply_supported_midspan_moment_and_strain() -> None:
    L = 10_000.0
    frame = beam(np.linspace(0.0, L, 11), supports=[0, 10])
    U = solve(frame, point_load(frame, 5))
    forces = end_forces(frame, U)[0]
    sagging = float(forces[4, 5])  # end of the element left of midspan
    assert sagging == pytest.approx(P * L / 4, rel=1e-9)
    assert float(-forces[5, 2]) == pytest.approx(P * L / 4, rel=1e-9)
    assert strain_at(frame, U, 4, 1.0) == pytest.approx(P * L / 4 * C_B / (E * INERTIA), rel=1e-6)
    # inside an element the moment is linear: at x = 2.5 m, M = P x / 2
    assert strain_at(frame, U, 2, 0.5) == pytest.approx(P * 2_500.0 / 2 * C_B / (E * INERTIA), rel=1e-6)
    w_mid = float(U[dof(5, 1), 0])
    assert w_mid == pytest.approx(-P * L**3 / (48 * E * INERTIA), rel=1e-9)


def test_two_span_continuous_support_moment() -> None:
    L, a = 10_000.0, 4_000.0  # equal spans; load at a in span 1
    x = np.linspace(0.0, 2 * L, 21)
    frame = beam(x, supports=[0, 10, 20])
    U = solve(frame, point_load(frame, 4))
    b = L - a
    expected = -P * a * b * (L + a) / (4 * L**2)
    forces = end_forces(frame, U)[0]
    assert float(forces[9, 5]) == pytest.approx(expected, rel=1e-9)
    strain_support = 0.5 * (strain_at(frame, U, 9, 1.0) + strain_at(frame, U, 10, 0.0))
    assert strain_support == pytest.approx(expected * C_B / (E * INERTIA), rel=1e-6)
    assert strain_support < 0.0  # hogging: bottom fibre in compression


def test_two_span_midpoint_load_gives_three_thirty_seconds() -> None:
    L = 8_000.0
    frame = beam(np.linspace(0.0, 2 * L, 17), supports=[0, 8, 16])
    U = solve(frame, point_load(frame, 4))
    assert float(end_forces(frame, U)[0][7, 5]) == pytest.approx(-3 * P * L / 32, rel=1e-9)


def test_vertical_cantilever_exercises_rotation() -> None:
    H, n = 4_000.0, 4
    nodes = np.column_stack([np.zeros(n + 1), np.linspace(0.0, H, n + 1)])
    frame = Frame(
        nodes=torch.as_tensor(nodes, dtype=torch.float64),
        elements=torch.as_tensor(np.column_stack([np.arange(n), np.arange(1, n + 1)])),
        EA=torch.full((n,), E * AREA, dtype=torch.float64),
        EI=torch.full((n,), E * INERTIA, dtype=torch.float64),
        fixed=torch.tensor([0, 1, 2]),
    )
    U = solve(frame, point_load(frame, n, force=P, component=0))
    assert float(U[dof(n, 0), 0]) == pytest.approx(P * H**3 / (3 * E * INERTIA), rel=1e-9)
    # base moment P·H; pushed towards +x, the column's +x face (the right-hand side looking from
    # base to top, i.e. the "bottom" fibre of this element) is compressed at the base
    strain = bottom_strain(frame, U, torch.tensor([0]), torch.tensor([0.0]), torch.tensor([C_B]))
    assert float(strain[0, 0]) == pytest.approx(-P * H * C_B / (E * INERTIA), rel=1e-6)


def test_axial_strain_of_a_bar() -> None:
    frame = beam(np.linspace(0.0, 5_000.0, 6), supports=[0, 5])
    U = solve(frame, point_load(frame, 5, force=P, component=0))
    assert strain_at(frame, U, 2, 0.3) == pytest.approx(P / (E * AREA), rel=1e-9)


def test_stiffness_is_symmetric_and_springs_add_to_the_diagonal() -> None:
    frame = beam(np.linspace(0.0, 3_000.0, 4), supports=[0, 3])
    K = stiffness(frame)
    assert torch.allclose(K, K.T, rtol=0, atol=1e-6 * K.abs().max())
    frame.spring_dofs, frame.spring_stiffness = torch.tensor([2]), torch.tensor([5.0e9])
    assert float(stiffness(frame)[2, 2] - K[2, 2]) == pytest.approx(5.0e9)

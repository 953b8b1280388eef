"""The plate example's model against the plate's series solutions (Navier, Lévy)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
import torch

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from examples.plate_dic.plate import PlateDIC  # noqa: E402

A, B, T, P, PATCH, ETA = 2.0, 1.5, 0.12, 50e3, 0.25, 0.75


def navier_strain(xy: np.ndarray, centre: float, rigidity: float, terms: int = 400) -> np.ndarray:
    """Bottom strain eps_xx [µε] of the simply supported plate, double sine series."""
    m, n = np.arange(1, terms + 1)[:, None], np.arange(1, terms + 1)[None, :]
    q = (16 * P / (np.pi**2 * m * n * PATCH**2) * np.sin(m * np.pi * centre / A) * np.sin(n * np.pi * ETA / B)
         * np.sin(m * np.pi * PATCH / (2 * A)) * np.sin(n * np.pi * PATCH / (2 * B)))
    w = q / (rigidity * np.pi**4 * (m**2 / A**2 + n**2 / B**2) ** 2)
    kxx = (m * np.pi / A) ** 2 * w  # -w_xx coefficients
    return np.array([1e6 * T / 2 * np.sum(kxx * np.sin(m * np.pi * x / A) * np.sin(n * np.pi * y / B)) for x, y in xy])


def _terms(s: float, c: object, x: object, linear: bool) -> np.ndarray:
    """Value and first three derivatives `4 x ...` at ``x`` of ``(x - c)**linear * exp(s (x - c))``."""
    x, c = np.asarray(x, dtype=float), np.asarray(c, dtype=float)
    e = np.exp(s * (x - c))
    k = np.arange(4).reshape(4, *([1] * x.ndim))
    if not linear:
        return s**k * e
    return (s**k * (x - c) + k * s ** np.maximum(k - 1, 0) * (k > 0)) * e


def levy_mode(alpha: float, load: float, centre: float, rigidity: float, k: float) -> np.ndarray:
    """Coefficients (4 per region) of ``X_n(x)`` for ``X'''' - 2a²X'' + a⁴X = q_n(x) / D``, ``q_n`` = ``load`` on
    the patch, with ``X = 0`` and ``D X'' = ± k X'`` at ``x = 0`` (+) and ``x = a`` (-)."""
    edges = [0.0, centre - PATCH / 2, centre + PATCH / 2, A]
    rows, rhs = [], []

    def basis(r: int, x: float) -> np.ndarray:  # 4 x 4: derivative order x function, region r
        lo, hi = edges[r], edges[r + 1]
        f = [_terms(alpha, hi, x, False), _terms(alpha, hi, x, True), _terms(-alpha, lo, x, False), _terms(-alpha, lo, x, True)]
        return np.stack(f, axis=1)

    particular = [0.0, load / (rigidity * alpha**4), 0.0]
    for r, x, sign in ((0, 0.0, 1.0), (2, A, -1.0)):
        bas = np.zeros((4, 12))
        bas[:, 4 * r: 4 * r + 4] = basis(r, x)
        rows += [bas[0], rigidity * bas[2] - sign * k * bas[1]]
        rhs += [-particular[r], 0.0]
    for r in (0, 1):
        bas = np.zeros((4, 12))
        bas[:, 4 * r: 4 * r + 4] = basis(r, edges[r + 1])
        bas[:, 4 * r + 4: 4 * r + 8] = -basis(r + 1, edges[r + 1])
        rows += list(bas)
        rhs += [particular[r + 1] - particular[r], 0.0, 0.0, 0.0]
    return np.linalg.solve(np.array(rows), np.array(rhs)), edges


def levy_strain(xy: np.ndarray, centre: float, rigidity: float, k: float, terms: int = 120) -> np.ndarray:
    """Bottom strain eps_xx [µε] with simply supported ``y`` edges and springs ``k`` on the ``x`` edges."""
    out = np.zeros(len(xy))
    for n in range(1, terms + 1):
        alpha = n * np.pi / B
        load = 4 * P / PATCH**2 / (n * np.pi) * np.sin(alpha * ETA) * np.sin(alpha * PATCH / 2)
        coef, edges = levy_mode(alpha, load, centre, rigidity, k)
        x = xy[:, 0]
        r = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, 2)
        lo, hi = np.asarray(edges)[r], np.asarray(edges)[r + 1]
        c = coef.reshape(3, 4)[r]  # points x 4
        second = (c[:, 0] * _terms(alpha, hi, x, False)[2] + c[:, 1] * _terms(alpha, hi, x, True)[2]
                  + c[:, 2] * _terms(-alpha, lo, x, False)[2] + c[:, 3] * _terms(-alpha, lo, x, True)[2])
        out += second * np.sin(alpha * xy[:, 1])
    return -1e6 * T / 2 * out


@pytest.fixture(scope="module")
def plate() -> PlateDIC:
    return PlateDIC()


def test_grid_and_shapes(plate: PlateDIC) -> None:
    assert plate.x.shape == (192, 2) and plate.names == ("E", "log10_k")
    assert float(plate.x[:, 0].min()) == 0.0625 and float(plate.x[:, 0].max()) == 1.9375
    out = plate(torch.tensor([[30.0, 6.0], [40.0, 7.0], [30.0, 6.0]]))
    assert out.shape == (3, 5, 192)
    assert torch.equal(out[0], out[2]) and torch.equal(out[0], plate(torch.tensor([30.0, 6.0])))


def test_simply_supported_plate_equals_navier_series(plate: PlateDIC) -> None:
    """k = 0: FD at h = a/32 within 0.6 % of the largest strain; at h = a/16 the error is over 3 times larger
    (second order: about 4)."""
    xy = plate.x.numpy()
    eps = plate.strains(torch.tensor([30.0]), torch.tensor([0.0]))[0].numpy()
    ref = np.stack([navier_strain(xy, c, 30.0 * plate.rigidity_per_gpa) for c in plate.loads.numpy()])
    err = np.abs(eps - ref).max()
    assert err < 0.006 * np.abs(ref).max()
    coarse = PlateDIC(cell=0.125)  # h = a/16: its grid nodes at 0.125 m
    eps_c = coarse.strains(torch.tensor([30.0]), torch.tensor([0.0]))[0].numpy()
    ref_c = np.stack([navier_strain(coarse.x.numpy(), c, 30.0 * coarse.rigidity_per_gpa) for c in coarse.loads.numpy()])
    assert np.abs(eps_c - ref_c).max() > 3.0 * err


@pytest.mark.parametrize("log10_k", [5.5, 6.5, 8.0])
def test_spring_edges_equal_levy_series(plate: PlateDIC, log10_k: float) -> None:
    """Rotational springs on x = 0, a: FD at h = a/32 within 1.2 % of the largest strain of the Lévy series (measured 0.43-0.91 %)."""
    xy = plate.x.numpy()
    eps = plate(torch.tensor([32.0, log10_k]))
    rigidity = 32.0 * plate.rigidity_per_gpa
    for j, c in enumerate(plate.loads.numpy()[[0, 2]]):
        ref = levy_strain(xy, float(c), rigidity, 10.0**log10_k)
        np.testing.assert_allclose(eps[2 * j].numpy(), ref, atol=0.012 * np.abs(ref).max(), rtol=0)


def test_woodbury_equals_direct_solve(plate: PlateDIC) -> None:
    """The small per-parameter system gives the field of the full stencil matrix solved directly."""
    small = PlateDIC(cell=0.125, loads=(0.5, 1.0))
    nx, ny, h = 16, 12, 0.125
    lap = np.kron(np.diag(-2.0 * np.ones(nx - 1)) + np.diag(np.ones(nx - 2), 1) + np.diag(np.ones(nx - 2), -1), np.eye(ny - 1)) \
        + np.kron(np.eye(nx - 1), np.diag(-2.0 * np.ones(ny - 1)) + np.diag(np.ones(ny - 2), 1) + np.diag(np.ones(ny - 2), -1))
    e, k = 25.0, 10**6.3
    rigidity = e * small.rigidity_per_gpa
    beta = k * h / (2 * rigidity)
    stencil = lap @ lap
    for i in (0, nx - 2):  # the ghost node w_-1 = r w_1 adds r (the SS case is r = -1)
        for j in range(ny - 1):
            stencil[i * (ny - 1) + j, i * (ny - 1) + j] += 1.0 + (beta - 1) / (beta + 1)
    gi, gj = np.meshgrid(np.arange(1, nx), np.arange(1, ny), indexing="ij")
    q = np.zeros(((nx - 1) * (ny - 1), 2))
    for col, c in enumerate((0.5, 1.0)):
        ox = np.clip(np.minimum(gi * h + h / 2, c + 0.125) - np.maximum(gi * h - h / 2, c - 0.125), 0, None)
        oy = np.clip(np.minimum(gj * h + h / 2, 0.875) - np.maximum(gj * h - h / 2, 0.625), 0, None)
        q[:, col] = (P / PATCH**2 * ox * oy / h**2).reshape(-1)
    w = h**4 / rigidity * np.linalg.solve(stencil, q)
    wxx = np.kron(np.diag(-2.0 * np.ones(nx - 1)) + np.diag(np.ones(nx - 2), 1) + np.diag(np.ones(nx - 2), -1), np.eye(ny - 1)) @ w / h**2
    expected = -1e6 * T / 2 * wxx.T
    np.testing.assert_allclose(small(torch.tensor([e, 6.3])).numpy(), expected, rtol=1e-10, atol=1e-10)


def test_stiffer_edges_raise_edge_hogging(plate: PlateDIC) -> None:
    eps = plate(torch.tensor([[30.0, 4.0], [30.0, 7.0], [30.0, 10.0]]))[:, 2]  # central patch
    mid = int(np.argmin(np.abs(plate.x[:, 0] - 1.0) + np.abs(plate.x[:, 1] - 0.75)))
    edge = int(np.argmin(np.abs(plate.x[:, 0] - 0.0625) + np.abs(plate.x[:, 1] - 0.75)))
    assert float(eps[:, mid].min()) > 90.0  # sagging under the patch whatever the edges
    assert eps[0, edge] > eps[1, edge] > eps[2, edge] and float(eps[2, edge]) < 0
    torch.testing.assert_close(plate(torch.tensor([60.0, 7.0 + np.log10(2.0)])), 0.5 * plate(torch.tensor([30.0, 7.0])))


def test_bad_inputs_are_named() -> None:
    with pytest.raises(ValueError, match="theta_p must end in 2"):
        PlateDIC()(torch.zeros(3))
    with pytest.raises(ValueError, match="cell 0.3 m must divide"):
        PlateDIC(cell=0.3)

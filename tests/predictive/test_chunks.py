"""The predictive's draws in chunks of parameter vectors equal the draws made all at once.

``RECORDED``: fingerprints (:func:`reference_predictive.fingerprint`) of small predictives of
every drawing form, recorded with the predictive as it was before its draws were chunked (every
copy of all draws at once), seeds as in :mod:`reference_predictive`, under the tests' float64
default dtype (the emulator's fit depends on it).
"""

from __future__ import annotations

import numpy as np
import pytest
import torch

from reference_predictive import CASES, fingerprint
from torchshm.predictive import chunks, draws
from torchshm.predictive.draws import line_draws
from torchshm.predictive.phases import draw_lines
from torchshm.predictive.view import Part, PredictionView
from torchshm.problem.matching import PositionMap

RECORDED = {
    "line_dense": [-5059.774506740658, 87620.06483843358, 19.938774361659405, -101.19549013481316, -174.65537342572782, -26.861092454918165, -5085.591289185437],
    "line_diagonal": [-764.6357755762701, 136931.0815504898, 69.38516724262428, -20.665831772331636, -132.4825018004156, 89.22151542303158, -738.9420553341565],
    "line_exact": [-3272.9362363347454, 55955.9048481447, -12.581570706911371, -99.17988594953775, -175.45172277743666, -27.681534427453666, -3332.1926316828567],
    "fibres_state_space": [2664.6332784557853, 2156027.3671373026, -37.364971227927455, 66.61583196139463, -2562.0198102407126, 2702.776697671332, -113.77552464460905],
    "per_line": [1671.6612233429923, 329034.25867168396, 28.787993700984003, 47.76174923837121, -1256.2028005308462, 1327.4687358150495, 392.9459045063836],
    "field_dense": [57356.307763398174, 3112913.7980423598, -203.5405739857917, 2389.846156808257, 752.6393914821829, 4111.805308168201, 58079.13557591202],
    "field_upscaled": [50504.294018774686, 2689740.7497922154, -24.093427883039766, 2404.9663818464132, 1029.6919970923566, 3800.0701241900592, 50717.78928194929],
    "inferred_noise": [188.40837246973007, 3065.457805505375, 20.49122555385693, 6.280279082324336, -114.31983169053316, 131.31718500932118, 100.03844457807216],
}


@pytest.fixture
def tiny_chunks(monkeypatch: pytest.MonkeyPatch) -> None:
    """Chunks of 16 draws (the fewest) and quantiles one point at a time."""
    monkeypatch.setattr(chunks, "CHUNK_BYTES", 1)
    monkeypatch.setattr(draws, "SUMMARY_CHUNK_BYTES", 1)


@pytest.mark.parametrize("name", list(CASES))
def test_same_numbers_as_before_chunking(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """21 to 50 draws in chunks of 16 (the last one 16 to 31) give the numbers of one chunk of
    all the draws, in the same process, to round-off; and the numbers recorded before chunking
    to 1e-4 (relative): the emulator's fit, an optimisation, moves them by up to 7e-6 between
    machines."""
    monkeypatch.setattr(chunks, "CHUNK_BYTES", 1 << 40)
    monkeypatch.setattr(draws, "SUMMARY_CHUNK_BYTES", 1 << 40)
    whole = fingerprint(CASES[name]())
    monkeypatch.setattr(chunks, "CHUNK_BYTES", 1)
    monkeypatch.setattr(draws, "SUMMARY_CHUNK_BYTES", 1)
    parts = fingerprint(CASES[name]())
    np.testing.assert_allclose(parts, whole, rtol=1e-10, atol=1e-9)
    np.testing.assert_allclose(parts, RECORDED[name], rtol=1e-4, atol=1e-6)


def test_summary_keeps_float32_draws_with_the_same_summary(tiny_chunks: None) -> None:
    full, summary = CASES["line_dense"](), CASES["line_dense"](keep="summary")
    assert summary.samples.dtype == torch.float32 and summary.eta is None
    scale = float(full.samples.abs().max())
    torch.testing.assert_close(summary.samples.double(), full.samples, rtol=0, atol=1e-6 * scale)
    for name in ("mean", "lower", "upper"):  # float32 round-off (2**-24 = 6e-8 relative)
        torch.testing.assert_close(getattr(summary, name), getattr(full, name), rtol=0, atol=1e-6 * scale)


@pytest.mark.parametrize("rows, values", [(50, 20), (33, 1), (16, 7), (15, 3), (2000, 156031), (47, 3)])
def test_row_chunks_are_multiples_of_16_with_a_last_one_of_16_or_more(rows: int, values: int) -> None:
    parts = chunks.row_chunks(rows, values, budget=8 * 16 * values)
    assert parts[0].start == 0 and parts[-1].stop == rows
    assert all(a.stop == b.start for a, b in zip(parts, parts[1:]))
    assert all((p.stop - p.start) % 16 == 0 for p in parts[:-1])
    assert len(parts) == 1 or parts[-1].stop - parts[-1].start >= 16


def _view(x: torch.Tensor, lines: int) -> PredictionView:
    """``lines`` lines of equal length over the points ``x`` (a field: one line)."""
    n = x.shape[0] // lines
    parts = tuple(Part(str(i), torch.arange(i * n, (i + 1) * n), i, 0.5 + 0.25 * i) for i in range(lines))
    label = None if lines == 1 else np.repeat([str(i) for i in range(lines)], n).astype(object)
    return PredictionView(x, label, PositionMap(np.arange(x.shape[0])), parts)


@pytest.mark.parametrize("kernel, x, lines, sigma_m", [
    ("matern32", torch.linspace(0.0, 30.0, 140), 2, 0.05),   # two lines of 70 points: state space
    ("squared_exponential", torch.linspace(0.0, 5.0, 30), 1, torch.linspace(0.0, 0.1, 45)),  # dense
    ("matern52", torch.cartesian_prod(torch.linspace(0, 1, 6), torch.linspace(0, 1, 5)), 1, 0.02),  # field
    ("separable_exponential", torch.cartesian_prod(torch.linspace(0, 1, 6), torch.linspace(0, 1, 5)), 1,
     0.02),  # a grid: the lattice form's AR(1) draws
])
def test_draw_lines_in_chunks_equal_line_draws(kernel: str, x: torch.Tensor, lines: int,
                                               sigma_m: float | torch.Tensor) -> None:
    """:func:`draw_lines` in chunks of 16 draws equals :func:`line_draws` of all 45 at once."""
    view, rng = _view(x.double(), lines), np.random.default_rng(0)
    eta = torch.as_tensor(rng.normal(100.0, 30.0, (45, 2, x.shape[0])))
    sigma_a = torch.as_tensor(rng.uniform(1.0, 3.0, (45, lines)))
    length = torch.as_tensor(rng.uniform(0.2, 0.6, (45, lines)))
    scale = torch.as_tensor(rng.uniform(0.5, 2.0, 45))
    want = line_draws(view, eta, kernel, sigma_a, length, sigma_m, torch.Generator().manual_seed(3), scale)
    got = eta.clone()
    draw_lines(got, view, kernel, sigma_a, length, sigma_m, torch.Generator().manual_seed(3),
               chunks.row_chunks(45, got[0].numel(), budget=1), scale)
    torch.testing.assert_close(got, want, rtol=1e-12, atol=1e-9)


@pytest.mark.parametrize("inferred_noise", [False, True])
def test_field_draws_of_the_vecchia_factor_in_chunks_equal_line_draws(inferred_noise: bool) -> None:
    """5041 points of a field (the full-scale form's draws: the Vecchia factor's solve), 32 draws
    in two chunks, with one noise level or one per draw."""
    x = torch.cartesian_prod(torch.linspace(0, 1, 71), torch.linspace(0, 1, 71))
    view, rng = _view(x, 1), np.random.default_rng(0)
    eta = torch.as_tensor(rng.normal(100.0, 30.0, (32, 1, x.shape[0])))
    sigma_a, length = torch.as_tensor(rng.uniform(1.0, 3.0, (32, 1))), torch.as_tensor(rng.uniform(0.05, 0.1, (32, 1)))
    scale = torch.as_tensor(rng.uniform(0.5, 2.0, 32)) if inferred_noise else None
    want = line_draws(view, eta, "matern52", sigma_a, length, 0.02, torch.Generator().manual_seed(3), scale)
    got = eta.clone()
    draw_lines(got, view, "matern52", sigma_a, length, 0.02, torch.Generator().manual_seed(3),
               chunks.row_chunks(32, x.shape[0], budget=1), scale)
    torch.testing.assert_close(got, want, rtol=1e-12, atol=1e-9)

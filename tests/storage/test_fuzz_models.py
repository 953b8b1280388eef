"""Fuzz: forward models that raise, return NaN, the wrong shape or the wrong dtype never make
``Problem.log_joint`` or the evaluation cache raise; each failure is kept with its error text."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import torch
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from torchshm.storage import CachedModel

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "inference"))
from inference_models import LinearModel, linear_gaussian_problem  # noqa: E402

FUZZ = settings(max_examples=40, derandomize=True, deadline=None, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])

EXCEPTIONS = st.sampled_from([RuntimeError, ValueError, TypeError, ZeroDivisionError, OSError,
                              MemoryError, IndexError, KeyError, AssertionError])
SHAPES = st.lists(st.integers(0, 70), min_size=0, max_size=4).map(tuple)
GARBAGE = st.one_of(
    st.none(), st.text(max_size=5), st.integers(), st.floats(allow_nan=True),
    st.lists(st.floats(allow_nan=True), max_size=4),
    st.sampled_from([np.array(["a", "b"]), np.zeros((2, 60), dtype=complex) + 1j,
                     np.zeros((2, 60), dtype=object), {"strain": 1}]),
)


class Hostile(LinearModel):
    """A LinearModel whose output is spoiled as drawn: an exception, NaN/inf entries, a
    wrong shape, or garbage instead of a tensor."""

    def __init__(self, spoil: tuple) -> None:
        super().__init__()
        self.spoil = spoil

    def __call__(self, theta_p):
        kind, arg = self.spoil
        out = super().__call__(theta_p)
        if kind == "raise":
            raise arg("hostile model")
        if kind == "nonfinite":
            flat = out.reshape(-1)
            for i, value in arg:
                flat[i % flat.numel()] = value
            return out
        if kind == "shape":
            return torch.zeros(arg, dtype=torch.float64)
        if kind == "dtype":
            return out.to(arg)
        return arg  # garbage


SPOILS = st.one_of(
    st.tuples(st.just("raise"), EXCEPTIONS),
    st.tuples(st.just("nonfinite"), st.lists(
        st.tuples(st.integers(0, 10_000), st.sampled_from([np.nan, np.inf, -np.inf])), min_size=1, max_size=5)),
    st.tuples(st.just("shape"), SHAPES.filter(lambda s: s not in ((2, 60), (1, 2, 60)))),
    st.tuples(st.just("dtype"), st.sampled_from([torch.float32, torch.float16, torch.int64, torch.bool])),
    st.tuples(st.just("garbage"), GARBAGE),
)
THETA = st.lists(st.tuples(st.floats(-3, 3), st.floats(-3, 3)), min_size=1, max_size=6)


@settings(FUZZ, max_examples=25)
@given(spoil=SPOILS, theta=THETA, use_store=st.booleans())
def test_log_joint_never_raises_and_failures_keep_their_error(spoil, theta, use_store, tmp_path) -> None:
    store = tmp_path / f"fuzz-{np.random.default_rng().integers(1 << 62)}.db" if use_store else None
    problem = linear_gaussian_problem(model=Hostile(spoil), store=store)
    value = np.asarray(problem.log_joint(np.array(theta)))
    assert value.shape == (len(theta),) and not np.isnan(value).any()
    theta_f, errors = problem.failures()
    if spoil[0] in ("raise", "shape", "garbage"):
        assert np.all(value == -np.inf) and errors and all(e.strip() for e in errors)
    elif spoil[0] == "nonfinite":  # the spoiled entries may hit some rows of a batch only
        assert (value == -np.inf).any() and errors and all("NaN" in e for e in errors)
    else:  # a real dtype is converted to float64: a result (with float rounding), not a failure
        assert np.isfinite(value).all() or errors


@FUZZ
@given(spoil=SPOILS)
def test_cache_returns_nan_rows_for_failures(spoil) -> None:
    cached = CachedModel(Hostile(spoil))
    out = cached(torch.tensor([[1.0, 2.0], [0.5, -1.0]], dtype=torch.float64))
    assert out.shape == (2, 2, 60) and out.dtype == torch.float64
    rows_ok = torch.isfinite(out.reshape(2, -1)).all(-1)
    assert int((~rows_ok).sum()) == len(cached.failures()[1])


def test_complex_output_is_a_failure_not_silently_real() -> None:
    """Found by the fuzz test above: a complex output must not lose its imaginary part."""
    cached = CachedModel(Hostile(("dtype", torch.complex128)))
    out = cached(torch.tensor([[1.0, 2.0]], dtype=torch.float64))
    assert torch.isnan(out).all() and "complex" in cached.failures()[1][0]

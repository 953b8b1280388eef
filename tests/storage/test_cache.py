"""The cache backends (in memory, evaluation store): one interface, the same answers, failures
recorded with their error text and never raised; the key rule of storage/keys.py only."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest
import torch

from torchshm.storage import CachedModel, EvaluationStore, MemoryBackend, StoreBackend, open_backend

PACKAGE = Path(__file__).resolve().parents[2] / "torchshm"


class Linear:
    """``eta[l, i] = theta_0 * (l + 1) + theta_1 * x_i``; NaN, a wrong shape or an exception
    where ``theta_0`` is 7, 8 or 9."""

    def __init__(self) -> None:
        self.x = torch.linspace(0.0, 1.0, 5, dtype=torch.float64)
        self.loads = torch.tensor([1.0, 2.0], dtype=torch.float64)
        self.identity = "cache-test-linear"
        self.calls = 0

    def __call__(self, theta: torch.Tensor) -> torch.Tensor:
        theta = torch.as_tensor(theta, dtype=torch.float64)
        self.calls += theta.reshape(-1, 2).shape[0]
        first = theta[..., 0]
        if bool((first == 9.0).any()):
            raise RuntimeError("solver diverged")
        out = first[..., None, None] * (self.loads[:, None] + 1.0) + theta[..., 1, None, None] * self.x
        out = torch.where((first == 7.0)[..., None, None], torch.nan, out)
        if bool((first == 8.0).any()):
            return out[..., :3]
        return out


@pytest.fixture(params=["memory", "store"])
def cached(request, tmp_path) -> CachedModel:
    store = None if request.param == "memory" else tmp_path / "s.db"
    return CachedModel(Linear(), store)


def test_open_backend_picks_the_backend(tmp_path) -> None:
    assert isinstance(open_backend(None), MemoryBackend) and open_backend(None).store is None
    backend = open_backend(tmp_path / "a.db")
    assert isinstance(backend, StoreBackend) and isinstance(backend.store, EvaluationStore)
    assert open_backend(backend) is backend
    with pytest.raises(TypeError, match="store must be None, a path or an EvaluationStore, got int"):
        open_backend(3)


def test_same_answers_and_one_evaluation_per_key(cached: CachedModel) -> None:
    theta = torch.tensor([[1.0, 2.0], [1.0 + 1e-14, 2.0], [3.0, 4.0]], dtype=torch.float64)
    out = cached(theta)
    expected = Linear()(theta[[0, 0, 2]])  # rows equal to 12 significant digits: one key
    assert torch.allclose(out, expected, rtol=0, atol=1e-12)
    assert cached.n_evaluations == 2
    cached(theta)
    assert cached.n_evaluations == 2  # nothing twice
    theta_p, outputs = cached.evaluations(2)
    assert theta_p.shape == (2, 2) and outputs.shape == (2, 2, 5)


@pytest.mark.parametrize("first, fragment", [
    (7.0, "NaN"), (8.0, "shape"), (9.0, "RuntimeError: solver diverged"),
])
def test_failed_run_is_nan_with_its_error_never_raised(cached: CachedModel, first: float, fragment: str) -> None:
    out = cached(torch.tensor([[first, 1.0], [1.0, 1.0]], dtype=torch.float64))
    assert torch.isnan(out[0]).all() and torch.isfinite(out[1]).all()  # the good row survives
    theta, errors = cached.failures()
    assert theta.tolist() == [[first, 1.0]] and len(errors) == 1 and fragment in errors[0], errors
    calls = cached.n_evaluations
    cached(torch.tensor([first, 1.0], dtype=torch.float64))
    assert cached.n_evaluations == calls  # a failure is not retried


def test_non_finite_vector_is_not_sent_to_the_model() -> None:
    cached = CachedModel(Linear())
    out = cached(torch.tensor([[np.nan, 1.0], [1.0, np.inf]], dtype=torch.float64))
    assert torch.isnan(out).all() and cached.model.calls == 0


def test_gradient_flows_in_memory_only(tmp_path) -> None:
    theta = torch.tensor([[1.0, 2.0]], dtype=torch.float64, requires_grad=True)
    CachedModel(Linear())(theta).sum().backward()
    assert theta.grad is not None and torch.isfinite(theta.grad).all()
    out = CachedModel(Linear(), tmp_path / "g.db")(theta)
    assert not out.requires_grad


def test_store_backend_keeps_runs_for_a_new_process(tmp_path) -> None:
    first = CachedModel(Linear(), tmp_path / "k.db")
    first(torch.tensor([[1.0, 2.0], [9.0, 1.0]], dtype=torch.float64))
    again = CachedModel(Linear(), EvaluationStore(tmp_path / "k.db"))
    out = again(torch.tensor([[1.0, 2.0], [9.0, 1.0]], dtype=torch.float64))
    assert again.n_evaluations == 0 and again.model.calls == 0
    assert torch.isfinite(out[0]).all() and torch.isnan(out[1]).all()
    assert again.failures()[1] == ["RuntimeError: solver diverged"]


def _imports(folder: Path) -> set[str]:
    names: set[str] = set()
    for path in folder.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.module:
                names.add(node.module)
            elif isinstance(node, ast.Import):
                names.update(alias.name for alias in node.names)
    return names


def test_likelihood_package_imports_nothing_from_storage() -> None:
    assert not [m for m in _imports(PACKAGE / "likelihood") if m.startswith("torchshm.storage")]


def test_the_key_rule_is_written_once() -> None:
    hits = [p for p in PACKAGE.rglob("*.py") if "SIGNIFICANT_DIGITS =" in p.read_text(encoding="utf-8")]
    assert [p.relative_to(PACKAGE).as_posix() for p in hits] == ["storage/keys.py"]

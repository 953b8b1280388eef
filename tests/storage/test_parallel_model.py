"""ParallelModel: the same strains as the model itself, rows spread over processes."""

from __future__ import annotations

import math

import torch

from torchshm.cli.models import with_executor
from torchshm.config import ExecutorConfig
from torchshm.forward import model_identity
from torchshm.storage import ParallelModel


class Linear:
    """strain[l, i] = theta_0 * x_i * load_l + theta_1 (NaN-free); picklable at module level."""

    names = ("a", "b")

    def __init__(self) -> None:
        self.x = torch.linspace(0.0, 1.0, 5, dtype=torch.float64)
        self.loads = torch.tensor([1.0, 2.0], dtype=torch.float64)

    def __call__(self, theta_p):
        t = torch.as_tensor(theta_p, dtype=torch.float64)
        if float(t[..., 0].min()) < 0:
            raise RuntimeError("negative a")
        return t[..., 0, None, None] * self.loads[:, None] * self.x + t[..., 1, None, None]


def test_parallel_model_matches_the_model() -> None:
    model = Linear()
    par = ParallelModel(model, n_jobs=2)
    theta = torch.tensor([[[1.0, 0.5], [2.0, -1.0]], [[3.0, 0.0], [1.0, 0.5]]])  # 2 x 2 x P
    out = par(theta)
    assert out.shape == (2, 2, 2, 5)
    assert torch.allclose(out, model(theta), rtol=0, atol=1e-12)
    assert par.identity == model_identity(model) and par.names == model.names


def test_failed_run_is_nan_row() -> None:
    out = ParallelModel(Linear(), n_jobs=2)(torch.tensor([[1.0, 0.0], [-1.0, 0.0]]))
    assert not torch.isnan(out[0]).any() and torch.isnan(out[1]).all()
    assert math.isnan(float(out[1, 0, 0]))


def test_serial_executor_keeps_the_model() -> None:
    model = Linear()
    assert with_executor(model, ExecutorConfig()) is model
    wrapped = with_executor(model, ExecutorConfig(kind="joblib", n_jobs=2))
    assert isinstance(wrapped, ParallelModel) and wrapped.n_jobs == 2

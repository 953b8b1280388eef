"""Problem with sensor lines, dropouts, per-line discrepancy and interpolated positions."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from torchshm import Measurements
from torchshm.likelihood import log_likelihood
from torchshm.priors import Uniform
from torchshm.problem import Problem

LOADS = (10.0, 20.0, 30.0)


class TwoLineModel:
    """Strains ``a * sin(x + load) + b * line_sign`` on two lines of 21 positions (0..2 m)."""

    names = ("a", "b")

    def __init__(self) -> None:
        grid = np.linspace(0.0, 2.0, 21)
        self.x = torch.as_tensor(np.concatenate([grid, grid]))
        self.line = np.array(["bottom"] * 21 + ["top"] * 21)
        self.loads = torch.tensor(LOADS, dtype=torch.float64)

    def __call__(self, theta: object) -> torch.Tensor:
        t = torch.as_tensor(theta, dtype=torch.float64)
        sign = torch.as_tensor(np.where(self.line == "top", -1.0, 1.0))
        wave = torch.sin(self.x[None, :] + self.loads[:, None])  # L x n
        return t[..., 0, None, None] * wave + t[..., 1, None, None] * sign


PRIORS = {"a": Uniform(0.0, 10.0), "b": Uniform(-5.0, 5.0), "sigma_a": Uniform(0.0, 5.0),
          "length": Uniform(0.01, 5.0)}
THETA = np.array([[2.0, 1.0, 0.7, 0.4], [3.0, -1.0, 1.5, 1.2]])


def campaign(rng: np.random.Generator, masked: bool = True) -> Measurements:
    model = TwoLineModel()
    y = model(torch.tensor([2.5, 0.5])).numpy() + rng.normal(0.0, 0.3, (3, 42))
    if masked:
        y[rng.random(y.shape) < 0.1] = np.nan
        y[1, 5:9] = np.nan  # a 0.4 m dropout
    return Measurements(model.x.numpy(), y, LOADS, sigma_e={"bottom": 0.2, "top": 0.4},
                        line=model.line, missing="mask" if masked else "error")


def test_masked_likelihood_equals_the_readings_deleted_by_hand(rng: np.random.Generator) -> None:
    m, model = campaign(rng), TwoLineModel()
    got = Problem(model, m, "matern32", PRIORS).log_likelihood(THETA)
    want = np.zeros(2)
    for i, load in enumerate(m.loads):
        for label, part in m.line_slices().items():
            keep = np.arange(part.start, part.stop)[m.mask[i, part]]
            one = Measurements(m.x[keep], m.y[i:i + 1, keep], [load], m.sigma_e_of(label), line=[label] * keep.size)
            want += Problem(model, one, "matern32", PRIORS).log_likelihood(THETA)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-10)


def test_one_line_of_two_is_the_plain_likelihood(rng: np.random.Generator) -> None:
    m, model = campaign(rng, masked=False), TwoLineModel()
    top = Measurements(m.x[21:], m.y[:, 21:], LOADS, 0.4, line=["top"] * 21)
    got = Problem(model, top, "exponential", PRIORS).log_likelihood(THETA)
    eta = model(torch.as_tensor(THETA[:, :2]))[:, :, 21:]
    want = log_likelihood(m.y[:, 21:], eta, m.x[21:], "exponential", torch.as_tensor(THETA[:, 2]),
                          torch.as_tensor(THETA[:, 3]), 0.05, 0.4)
    np.testing.assert_array_equal(got, want.numpy())


def test_per_line_discrepancy_names_priors_and_values(rng: np.random.Generator) -> None:
    m, model = campaign(rng), TwoLineModel()
    priors = {**PRIORS, "sigma_a[top]": Uniform(0.0, 9.0)}
    p = Problem(model, m, "matern32", priors, discrepancy="per_line")
    assert p.names == ["a", "b", "sigma_a[bottom]", "length[bottom]", "sigma_a[top]", "length[top]"]
    assert p.hard_bounds[4].tolist() == [0.0, 9.0] and p.hard_bounds[2].tolist() == [0.0, 5.0]
    shared = Problem(model, m, "matern32", PRIORS)
    same = np.column_stack([THETA, THETA[:, 2:]])  # equal parameters on both lines
    np.testing.assert_allclose(p.log_likelihood(same), shared.log_likelihood(THETA), rtol=0, atol=1e-10)
    with pytest.raises(ValueError, match=r"entry 'sigma_a\[top\]' does not fit"):
        Problem(model, m, "matern32", priors)


def test_interpolated_positions(rng: np.random.Generator) -> None:
    model = TwoLineModel()
    x = np.array([0.05, 0.1, 1.37, 2.0])
    m = Measurements(np.concatenate([x, x[:2]]), rng.normal(size=(3, 6)), LOADS,
                     line=["top"] * 4 + ["bottom"] * 2)
    p = Problem(model, m, "matern32", PRIORS, match="interpolate")
    out = model(torch.tensor([[2.0, 1.0]]))
    got = p.at_measured(out)[0].numpy()
    grid = np.linspace(0.0, 2.0, 21)
    want_top = [np.interp(x, grid, row[21:]) for row in out[0].numpy()]
    np.testing.assert_allclose(got[:, :4], want_top, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(got[:, 5], out[0, :, 1].numpy())  # on a model position: exact
    with pytest.raises(ValueError, match="Problem.x_index: positions are interpolated"):
        p.x_index
    with pytest.raises(ValueError, match=r"measured positions not produced by the model.*0\.05"):
        Problem(model, m, "matern32", PRIORS)


@pytest.mark.parametrize("x, line, message", [
    ([1.5, 2.4, 3.0], ["top"] * 3, r"2 measured position\(s\) on line 'top' fall outside the model \(0..2 m.*: 2.4, 3"),
    ([0.5], ["side"], r"measured line 'side' is not among the model's lines \['bottom', 'top'\]"),
    ([0.5], None, "the model has lines .* but the measurements name none"),
])
def test_positions_the_model_does_not_cover(x: list[float], line: list[str] | None, message: str) -> None:
    m = Measurements(x, np.ones((1, len(x))), [10.0], line=line)
    with pytest.raises(ValueError, match=message):
        Problem(TwoLineModel(), m, "matern32", PRIORS, match="interpolate")


def test_two_lines_need_a_model_with_lines(rng: np.random.Generator) -> None:
    class OneLine(TwoLineModel):
        def __init__(self) -> None:
            super().__init__()
            del self.line

    with pytest.raises(ValueError, match="the measurements have 2 lines .* the model declares no `line`"):
        Problem(OneLine(), campaign(rng), "matern32", PRIORS)
    with pytest.raises(ValueError, match="match must be 'exact' or 'interpolate'"):
        Problem(TwoLineModel(), campaign(rng), "matern32", PRIORS, match="nearest")
    with pytest.raises(ValueError, match="discrepancy must be 'shared' or 'per_line'"):
        Problem(TwoLineModel(), campaign(rng), "matern32", PRIORS, discrepancy="lines")


def test_per_line_noise_and_predictive_view(rng: np.random.Generator) -> None:
    from torchshm.predictive import prediction_view

    p = Problem(TwoLineModel(), campaign(rng), "matern32", PRIORS)
    assert p.sigma_e == {"bottom": 0.2, "top": 0.4}
    assert sorted({(b.line, b.sigma_e) for b in p.blocks}) == [("bottom", 0.2), ("top", 0.4)]
    assert Problem(TwoLineModel(), campaign(rng), "matern32", PRIORS, sigma_e=0.3).sigma_e == 0.3
    view = prediction_view(p)  # the predictive draws each line with its own noise
    assert [(part.line, part.sigma_e) for part in view.parts] == [("bottom", 0.2), ("top", 0.4)]

"""``Problem``: parameter bookkeeping, data matching, caching, and bad input."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from problem_models import LinearModel, synthetic

import torchshm
from torchshm import Gamma, Problem, Uniform, log_likelihood
from torchshm.kernels import KERNELS

THETA = np.array([33.0, 11.5, 0.9, 2.0])


@pytest.mark.parametrize("kernel", KERNELS)
def test_names_and_bounds(kernel: str, small) -> None:
    problem = Problem(*small, kernel=kernel)
    want = ["E_c", "log10_K_r", "sigma_a"] + ([] if kernel == "independent" else ["length"])
    assert problem.names == want
    assert problem.physical_names == ["E_c", "log10_K_r"]
    assert list(problem.priors) == want
    table4 = {
        "E_c": (10, 100, 20, 60),
        "log10_K_r": (0, 12, 1, 11),
        "sigma_a": (0, 5, 0.2, 2),
        "length": (0, 10, 0.2, 5),
    }
    np.testing.assert_array_equal(problem.hard_bounds, [table4[n][:2] for n in want])
    np.testing.assert_array_equal(problem.plausible_bounds, [table4[n][2:] for n in want])
    draws = problem.sample_prior(500, np.random.default_rng(1))
    assert draws.shape == (500, len(want))
    assert ((draws >= problem.hard_bounds[:, 0]) & (draws <= problem.hard_bounds[:, 1])).all()


def test_log_joint_is_log_prior_plus_log_likelihood(small) -> None:
    model, meas = small
    problem = Problem(model, meas, kernel="matern52")
    priors = torchshm.paper_priors()
    want_prior = sum(
        float(priors[n].log_prob(v)) for n, v in zip(problem.names, THETA, strict=True)
    )
    assert problem.log_prior(THETA) == pytest.approx(want_prior, rel=1e-14)
    eta = model(torch.as_tensor(THETA[:2]))[[4, 1, 7]][
        :, ::2
    ]  # loads 39.8, 16.9, 62.8; every other x
    want = log_likelihood(meas.y, eta, meas.x, "matern52", 0.9, 2.0, sigma_m=0.05, sigma_e=0.1)
    assert problem.log_likelihood(THETA) == pytest.approx(float(want), rel=1e-13)
    assert problem.log_joint(THETA) == pytest.approx(float(want) + want_prior, rel=1e-13)


def test_numpy_in_numpy_out_torch_in_torch_out(small) -> None:
    problem = Problem(*small)
    one = problem.log_joint(THETA)
    assert isinstance(one, np.floating) and np.ndim(one) == 0
    batch = np.broadcast_to(THETA, (2, 3, 4)) * np.linspace(0.9, 1.1, 3)[:, None]
    out = problem.log_joint(batch)
    assert isinstance(out, np.ndarray) and out.shape == (2, 3)
    t = problem.log_joint(torch.as_tensor(batch))
    assert isinstance(t, torch.Tensor) and t.shape == (2, 3)
    np.testing.assert_array_equal(t.numpy(), out)
    assert problem.log_joint(THETA.tolist()) == one


def test_each_distinct_vector_is_evaluated_once(small) -> None:
    model, meas = small
    problem = Problem(model, meas)
    theta = np.array(
        [THETA, THETA * [1, 1, 1.2, 0.5], THETA * [1 + 1e-14, 1, 1, 1], THETA * [1.1, 1, 1, 1]]
    )
    problem.log_joint(theta)
    assert problem.n_model_evaluations == 2 and len(model.calls) == 2
    problem.log_joint(theta[::-1])  # in-process cache: nothing new
    assert problem.n_model_evaluations == 2 and len(model.calls) == 2
    theta_p, outputs = problem.evaluations()
    np.testing.assert_allclose(theta_p, [[33.0, 11.5], [36.3, 11.5]])
    assert outputs.shape == (2, 12, 61)
    np.testing.assert_allclose(outputs[1], model(torch.tensor([36.3, 11.5])).numpy(), rtol=1e-12)


def test_model_outputs_keeps_batch_shape(small) -> None:
    problem = Problem(*small)
    out = problem.model_outputs(np.array([[[30.0, 5.0]], [[40.0, 6.0]]]))
    assert isinstance(out, torch.Tensor) and out.shape == (2, 1, 12, 61)


def test_only_measured_loads_and_positions_are_used(small) -> None:
    """Shuffled model loads: the likelihood must pick rows by load value, not by position."""
    model, meas = small
    shuffled = LinearModel(model.x.numpy(), loads=tuple(model.loads.numpy()[::-1]))
    a = Problem(model, meas).log_likelihood(THETA)
    b = Problem(shuffled, meas).log_likelihood(THETA)
    assert a == pytest.approx(b, rel=1e-13)


def test_outside_support_is_minus_inf_without_a_model_call(small) -> None:
    model, meas = small
    problem = Problem(model, meas)
    bad = np.array(
        [
            [5.0, 11.5, 0.9, 2.0],
            [33.0, 12.5, 0.9, 2.0],
            [33.0, 11.5, -0.1, 2.0],
            [33.0, 11.5, 0.9, 10.5],
            [np.nan, 11.5, 0.9, 2.0],
            [33.0, np.inf, 0.9, 2.0],
        ]
    )
    for fn in (problem.log_joint, problem.log_prior, problem.log_likelihood):
        out = fn(bad)
        assert np.all(out == -np.inf)
    assert problem.n_model_evaluations == 0 and model.calls == []


def test_non_finite_model_output_is_minus_inf(small) -> None:
    model, meas = small
    problem = Problem(LinearModel(model.x.numpy(), nan_above=50.0), meas)
    out = problem.log_joint(np.array([THETA, [60.0, 11.5, 0.9, 2.0]]))
    assert np.isfinite(out[0]) and out[1] == -np.inf
    assert len(problem.evaluations()[0]) == 1  # the failed run is not an evaluation to reuse


def test_gradient_flows_through_the_model(small) -> None:
    model, meas = small
    problem = Problem(model, meas, kernel="matern32")
    theta = torch.as_tensor(THETA).requires_grad_(True)
    problem.log_joint(theta).backward()
    fd = np.empty(4)
    for i in range(4):
        h = 1e-6 * abs(THETA[i])
        up, down = THETA.copy(), THETA.copy()
        up[i] += h
        down[i] -= h
        fd[i] = (problem.log_joint(up) - problem.log_joint(down)) / (2 * h)
    np.testing.assert_allclose(theta.grad.numpy(), fd, rtol=1e-5)


def test_fixed_parameters_leave_names(small) -> None:
    model, meas = small
    priors = {
        "E_c": 35.0,
        "log10_K_r": Uniform(0, 12),
        "sigma_a": Gamma(2, 2, bounds=(0, 5)),
        "length": 1.5,
    }
    problem = Problem(model, meas, priors=priors)
    assert problem.names == ["log10_K_r", "sigma_a"]
    assert problem.physical_names == ["E_c", "log10_K_r"]
    full = Problem(model, meas, priors={**priors, "E_c": Uniform(10, 100), "length": Gamma(3, 1)})
    assert problem.log_likelihood([11.0, 0.7]) == pytest.approx(
        float(full.log_likelihood([35.0, 11.0, 0.7, 1.5]))
    )
    assert model.calls[0] == [35.0, 11.0]


def test_physical_parameters_follow_the_model_order(small) -> None:
    model, meas = small
    priors = {
        "sigma_a": Gamma(2, 2, bounds=(0, 5)),
        "log10_K_r": Uniform(0, 12),
        "E_c": Uniform(10, 100),
    }
    problem = Problem(model, meas, kernel="independent", priors=priors)
    assert problem.names == ["E_c", "log10_K_r", "sigma_a"]
    problem.log_joint([33.0, 11.5, 0.9])
    assert model.calls == [[33.0, 11.5]]


def test_dict_order_without_model_names(small) -> None:
    model, meas = small
    model.names = None  # a model that does not declare its parameters
    priors = {"E_c": Uniform(10, 100), "K": Uniform(0, 12), "sigma_a": Gamma(2, 2, bounds=(0, 5))}
    assert Problem(model, meas, kernel="independent", priors=priors).names == [
        "E_c",
        "K",
        "sigma_a",
    ]


def test_sigma_e_defaults_to_the_measurements(small) -> None:
    model, meas = small
    meas.sigma_e = 0.3
    assert Problem(model, meas).sigma_e == 0.3
    assert Problem(model, meas, sigma_e=0.2).sigma_e == 0.2


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"kernel": "matern12"}, "unknown kernel 'matern12'"),
        ({"sigma_m": -0.05}, "sigma_m"),
        ({"sigma_e": -0.1}, "sigma_e"),
        (
            {"priors": {**torchshm.paper_priors(), "E_s": Uniform(0, 1)}},
            r"unknown parameter\(s\) \['E_s'\]",
        ),
        ({"priors": {"E_c": Uniform(10, 100), "sigma_a": 1.0, "length": 1.0}}, "log10_K_r"),
        ({"priors": {"E_c": Uniform(10, 100), "log10_K_r": 11.0, "length": 1.0}}, "sigma_a"),
        ({"priors": {"E_c": Uniform(10, 100), "log10_K_r": 11.0, "sigma_a": 1.0}}, "length"),
        ({"priors": {**torchshm.paper_priors(), "E_c": "uniform"}}, "'E_c'"),
        ({"priors": {**torchshm.paper_priors(), "sigma_a": -1.0}}, "sigma_a"),
    ],
)
def test_bad_input_is_named(change: dict[str, object], message: str, small) -> None:
    with pytest.raises(ValueError, match=message):
        Problem(*small, **change)


def test_unknown_loads_and_positions_are_named(small) -> None:
    model, meas = small
    with pytest.raises(ValueError, match=r"load cases not produced by the model.*: 40\.5"):
        Problem(
            model, synthetic(LinearModel(model.x.numpy(), loads=(39.8, 40.5)), (39.8, 40.5), meas.x)
        )
    off_grid = np.round(meas.x + 0.02, 10)
    other = LinearModel(off_grid)
    with pytest.raises(ValueError, match=r"positions not produced by the model.*35\.02"):
        Problem(model, synthetic(other, (39.8,), off_grid))
    beyond = np.round(np.append(meas.x, 40.0), 10)
    with pytest.raises(ValueError, match="positions not produced by the model.*: 40"):
        Problem(model, synthetic(LinearModel(beyond), (39.8,), beyond))


def test_positions_match_within_a_micrometre(small) -> None:
    model, meas = small
    shifted = LinearModel(model.x.numpy() + 4e-7)
    assert np.array_equal(Problem(shifted, meas).x_index, np.arange(0, 61, 2))


def test_wrong_theta_shape_is_named(small) -> None:
    with pytest.raises(ValueError, match=r"theta must have shape \(\.\.\., 4\)"):
        Problem(*small).log_joint(np.zeros(3))

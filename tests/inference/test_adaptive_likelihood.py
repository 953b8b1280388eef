"""The emulated log joint's sd far from the posterior (:meth:`EmulatedLogJoint.value_and_sd`).

Checked against a Monte Carlo of the exact Eq. (21) likelihood over draws of the emulator's
strain field at one point, its error correlated across readings as the runs' fields are
(:attr:`FieldEmulator.error_basis`): the delta-method sd with the exact gradient must match it,
with a strong smooth discrepancy (which absorbs a smooth misfit) as well as with a white one.
"""

from __future__ import annotations

import numpy as np
import pytest
import torch

from inference_models import WaveModel

from torchshm import Measurements, Problem, Uniform
from torchshm.inference.adaptive.field import FieldEmulator
from torchshm.inference.adaptive.likelihood import EmulatedLogJoint


@pytest.mark.parametrize("kernel, sigma_a, length", [("squared_exponential", 2.0, 1.0),
                                                     ("independent", 0.5, None)])
def test_sd_far_from_the_posterior_matches_a_monte_carlo(kernel: str, sigma_a: float,
                                                         length: float | None) -> None:
    model = WaveModel(40)
    rng = np.random.default_rng(0)
    y = model(torch.tensor([0.4, 0.6])).numpy() + 0.3 * rng.standard_normal((1, 40))
    priors = {"a": Uniform(0.0, 1.0), "b": Uniform(0.0, 1.0), "sigma_a": sigma_a}
    if length is not None:
        priors["length"] = length
    problem = Problem(model, Measurements(model.x.numpy(), y, model.loads.numpy(), sigma_e=0.1),
                      kernel=kernel, sigma_m=0.0, priors=priors)
    side = np.linspace(0.0, 1.0, 4)
    theta = np.stack(np.meshgrid(side, side), -1).reshape(-1, 2)
    emulator = FieldEmulator.fit(theta, np.asarray(problem.model_outputs(theta)), model.x,
                                 model.loads)
    log_joint = EmulatedLogJoint(problem, emulator)
    row = np.array([[0.85, 0.15]])  # far from the truth (0.4, 0.6) and between runs
    value, sd = log_joint.value_and_sd(row)
    mean, var, rows = log_joint.parts(row)
    basis = emulator.error_basis  # m x N
    z = torch.randn((4000, basis.shape[1]), dtype=mean.dtype,
                    generator=torch.Generator().manual_seed(1))
    fields = mean + var.sqrt() * (z @ basis.mT).reshape(4000, *mean.shape[1:])
    draws = log_joint.at(fields, var.expand_as(fields), rows.expand(4000, -1))
    assert value[0] < np.median(draws) + 5 * sd[0]
    # the exploration's value is the likelihood with the emulator's variance on the diagonal;
    # the posterior's (log_joint) is the plug-in Eq. (21) at the emulator's mean
    marginal = float(np.asarray(problem.log_prior(row)).reshape(-1)[0]) + log_joint.at(mean, var, rows)[0]
    assert value[0] == pytest.approx(marginal, abs=1e-9)
    assert log_joint(row)[0] == pytest.approx(
        float(np.asarray(problem.log_prior(row)).reshape(-1)[0]) + log_joint.at(mean, None, rows)[0], abs=1e-9)
    # the delta method against 4,000 exact evaluations: within 15 % (the sampling error is 2 %)
    assert sd[0] == pytest.approx(draws.std(), rel=0.15)


def test_a_likelihood_without_gradient_is_said_once(caplog, monkeypatch) -> None:
    """A form that returns constants (kernel 'upscaled' through its sparse LU) leaves the error
    model without ∂ℓ/∂η: one warning per process says the sd is understated, and names the way out."""
    from torchshm.inference.adaptive import likelihood

    monkeypatch.setattr(likelihood, "_WARNED_NO_GRADIENT", False)
    with caplog.at_level("WARNING", logger=likelihood.__name__):
        likelihood._warn_no_gradient("upscaled")
        likelihood._warn_no_gradient("upscaled")
    said = [r.getMessage() for r in caplog.records if "no gradient" in r.getMessage()]
    assert len(said) == 1 and "understates" in said[0] and "method='vbmc'" in said[0]

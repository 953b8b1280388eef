"""The GP emulator of stored model outputs (the surrogate's shared-kernel GP on given arrays)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from torchshm.casestudy import Bridge705
from torchshm.predictive.emulator import PLAIN, clean_design, fit_emulator, transform_options

X = np.linspace(0.0, 10.0, 30)
LOADS = np.array([1.0, 2.0])


def response(theta: np.ndarray) -> np.ndarray:
    """A smooth nonlinear `M x 2 x 30` response, like strains against (E, log10 K)."""
    e, k = theta[:, :1], theta[:, 1:]
    s = 1.0 / (1.0 + np.exp(-(k - 6.0)))
    return np.stack([100.0 / e * np.sin(X / 3 + s), 100.0 / e * np.cos(X / 4 - s)], axis=1)


def test_accurate_inside_the_design() -> None:
    rng = np.random.default_rng(0)
    design = np.column_stack([rng.uniform(20, 50, 60), rng.uniform(4, 12, 60)])
    emulator = fit_emulator(design, response(design), X, LOADS, transform=Bridge705.surrogate_transform)
    test = np.column_stack([rng.uniform(25, 45, 200), rng.uniform(5, 11, 200)])
    mean, var = emulator.predict(test)
    assert mean.shape == (200, 2, 30) and var.shape == (200, 2, 30)
    err = np.abs(mean.detach().numpy() - response(test)).max()
    assert err < 0.05, err


def test_sd_grows_away_from_data() -> None:
    rng = np.random.default_rng(1)
    design = np.column_stack([rng.uniform(30, 35, 20), rng.uniform(9, 10, 20)])
    emulator = fit_emulator(design, response(design), X, LOADS)
    var_in = emulator.variance(design[:5])
    var_out = emulator.variance(np.array([[80.0, 2.0]]))
    assert var_in.max() < 1e-2 * var_out.max()


def test_drops_failed_and_repeated_rows() -> None:
    rng = np.random.default_rng(2)
    design = np.column_stack([rng.uniform(20, 50, 10), rng.uniform(4, 12, 10)])
    outputs = response(design)
    outputs[3] = np.nan
    theta, out = clean_design(np.vstack([design, design[:2]]), np.concatenate([outputs, outputs[:2]]))
    assert theta.shape[0] == 9 and out.shape == (9, 2, 30)
    with pytest.raises(ValueError, match="at least 4 are needed"):
        fit_emulator(design[:3], outputs[:3], X, LOADS)


def test_transform_choice() -> None:
    """The model's own transform when it declares one (the bridge does), plain otherwise."""

    class Declared:
        surrogate_transform = {"log_inputs": (1,), "modulus": None, "relative_to_modulus": ()}

    assert transform_options(Declared()) == Declared.surrogate_transform
    assert transform_options(object()) == PLAIN
    assert transform_options(Bridge705.__new__(Bridge705)) == {
        "log_inputs": (0,), "modulus": 0, "relative_to_modulus": (1,)}


def test_compressed_targets_give_the_same_marginal_likelihood() -> None:
    """At any hyperparameters, N compressed outputs give the mean log marginal likelihood per
    output of all m outputs (it depends on the targets only through YᵀY / m)."""
    from torchshm.predictive.emulator import compressed_targets
    from torchshm.surrogate.gp import SharedKernelGP

    rng = np.random.default_rng(3)
    inputs = torch.as_tensor(rng.uniform(0, 1, (15, 2)))
    targets = torch.as_tensor(rng.normal(0, 1, (200, 15)))  # m = 200 outputs of N = 15 runs
    full, small = SharedKernelGP(inputs, targets), SharedKernelGP(inputs, compressed_targets(targets))
    assert small.train_targets.shape == (15, 15)
    for lengthscale, noise in ((0.3, 1e-4), (1.5, 0.2)):
        for gp in (full, small):
            gp.covar_module.base_kernel.lengthscale = lengthscale
            gp.likelihood.noise = noise
        with torch.no_grad():
            a, b = float(full.log_marginal_likelihood().mean()), float(small.log_marginal_likelihood().mean())
        assert a == pytest.approx(b, rel=1e-10)


def test_many_outputs_fit_like_the_full_fit() -> None:
    """More outputs than runs: the compressed fit finds the full fit's hyperparameters."""
    from torchshm.surrogate import ResponseTransform
    from torchshm.surrogate.surrogate import build_gp

    rng = np.random.default_rng(4)
    design = np.column_stack([rng.uniform(20, 50, 25), rng.uniform(4, 12, 25)])
    outputs = response(design)  # 25 runs x 60 outputs
    emulator = fit_emulator(design, outputs, X, LOADS)
    theta, out = clean_design(design, outputs)
    scaling = ResponseTransform.fit(theta, out.reshape(25, -1), standardize="output", **PLAIN)
    gp = build_gp(scaling, theta, out, "rbf", 1e-10)
    full = gp.fit()
    assert emulator.metadata["log_marginal_likelihood"] == pytest.approx(full, rel=1e-6, abs=1e-6)
    test = np.column_stack([rng.uniform(25, 45, 50), rng.uniform(5, 11, 50)])
    mean, _ = emulator.predict(test)
    theta_test = torch.as_tensor(test, dtype=torch.float64)
    other = scaling.strains(theta_test, gp.predict(scaling.inputs(theta_test), False)[0])
    np.testing.assert_allclose(mean.reshape(50, -1).detach().numpy(), other.detach().numpy(), atol=1e-4)


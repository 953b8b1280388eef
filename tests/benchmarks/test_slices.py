"""The slice quadrature of a peak with a long plateau against the exact integrals."""

from __future__ import annotations

import numpy as np
from scipy import integrate as quad
from scipy.special import expit

from benchmarks.slices import check_importance, conditional_slices, integrate

SIGMA = 0.5


def _height(k: np.ndarray) -> np.ndarray:
    """Log height of the marginal: a plateau 8 nats under a peak against the bound 12."""
    return -8.0 + 8.0 * expit((k - 11.0) / 0.2)


def _log_joint(theta: np.ndarray) -> np.ndarray:
    """``k`` in [0, 12] with height :func:`_height`, ``x | k`` normal around ``k / 12``, `B x 2`."""
    theta = np.atleast_2d(theta)
    k, x = theta[:, 0], theta[:, 1]
    out = _height(k) - 0.5 * np.square((x - k / 12.0) / SIGMA) - np.log(SIGMA * np.sqrt(2 * np.pi))
    return np.where((k >= 0) & (k <= 12), out, -np.inf)


def test_slices_match_the_exact_tail_mass_and_moments() -> None:
    grid = np.concatenate([np.arange(0.0, 9.0, 0.5), np.linspace(9.0, 12.0, 61)])
    slices = conditional_slices(_log_joint, 0, grid, np.array([11.8, 1.0]), np.array([10.0, 2.0]),
                                n=600, seed=0)
    error = np.abs(slices["log_z"] - _height(grid))  # the conditional is normalised: log Z = height
    assert np.all(error < 4 * slices["log_z_sd"]) and np.max(slices["log_z_sd"]) < 0.06
    res = integrate(grid, slices, 0, (8.0, 10.0), n_perturb=50)

    def weight(k: float) -> float:
        return float(np.exp(_height(np.array(k))))

    total = quad.quad(weight, 0, 12, points=[11.0])[0]
    tail = [quad.quad(weight, 0, t)[0] / total for t in (8.0, 10.0)]
    mean_k = quad.quad(lambda k: k * weight(k), 0, 12, points=[11.0])[0] / total
    var_k = quad.quad(lambda k: (k - mean_k) ** 2 * weight(k), 0, 12, points=[11.0])[0] / total
    sd_x = np.sqrt(var_k / 144.0 + SIGMA**2)  # x = k / 12 + noise
    assert 0.002 < tail[0] < 0.2  # a small mass far away, as in the bridge campaign
    assert np.allclose(res["tail_mass"], tail, rtol=0.03)
    assert abs(res["mean"][0] - mean_k) < 0.02 and abs(res["sd"][0] / np.sqrt(var_k) - 1) < 0.02
    assert abs(res["mean"][1] - mean_k / 12.0) < 0.02 and abs(res["sd"][1] / sd_x - 1) < 0.03
    check = check_importance(_log_joint, 0, grid, slices, (8.0, 10.0), n=4000)
    assert np.allclose(check["tail_mass"], tail, atol=4 * np.max(check["tail_mass_sd"]))
    assert abs(check["mean"][0] - mean_k) < 0.1 and check["ess"] > 1000

"""Mode search and mode-spanning chains of the adaptive method, on an analytic two-mode density."""

from __future__ import annotations

import numpy as np
from scipy.special import logsumexp

from torchshm.inference.adaptive import modes, sampling

CENTRES = np.array([[-3.0, 1.0], [3.0, -1.0]])
SD = 0.3
WEIGHT_B = 0.3  # mass of the second mode


def two_modes(theta: np.ndarray) -> np.ndarray:
    """Log density `B` of an equal-width mixture of two Gaussians (weights 0.7, 0.3), rows `B x 2`."""
    theta = np.atleast_2d(theta)
    d2 = np.square(theta[:, None, :] - CENTRES[None]).sum(-1) / SD**2
    out = logsumexp(-0.5 * d2 + np.log([1 - WEIGHT_B, WEIGHT_B]), axis=1)
    inside = (np.abs(theta) <= 6.0).all(axis=1)
    return np.where(inside, out, -np.inf)


HARD = np.array([[-6.0, 6.0], [-6.0, 6.0]])
PLAUSIBLE = np.array([[-5.0, 5.0], [-5.0, 5.0]])


def test_find_modes_returns_both_maxima() -> None:
    rng = np.random.default_rng(0)
    starts = np.vstack([CENTRES + 0.4 * rng.standard_normal((2, 2)), [[-2.0, 0.0], [2.5, 0.0]]])
    found, values = modes.find_modes(two_modes, starts, HARD, PLAUSIBLE)
    assert found.shape == (2, 2)
    np.testing.assert_allclose(found, CENTRES, atol=1e-3)  # best (heavier) mode first
    assert values[0] - values[1] > 0.0


def test_chain_from_one_mode_gets_both_shares() -> None:
    rng = np.random.default_rng(1)
    walkers = CENTRES[0] + SD * rng.standard_normal((64, 2))  # every walker in the first mode
    found, values = modes.find_modes(two_modes, np.vstack([walkers[:1], [[2.5, 0.0]]]), HARD,
                                     PLAUSIBLE)
    spread = modes.spread_walkers(walkers, found, values, 15.0, np.ones(2), rng)
    share = float((spread[:, 0] > 0).mean())
    assert abs(share - WEIGHT_B) < 0.05  # Laplace share: equal widths, so the weights
    samples, _ = sampling.run_chain(two_modes, spread, 400, seed=2, hop=True)
    np.testing.assert_allclose((samples[:, 0] > 0).mean(), WEIGHT_B, atol=0.06)
    unmoved, _ = sampling.run_chain(two_modes, walkers, 400, seed=2, hop=True)
    assert (unmoved[:, 0] > 0).mean() == 0.0  # without the spread no walker finds the other mode


def test_single_mode_leaves_walkers_alone() -> None:
    rng = np.random.default_rng(3)
    walkers = CENTRES[0] + SD * rng.standard_normal((32, 2))
    out = modes.spread_walkers(walkers, CENTRES[:1], np.zeros(1), 15.0, np.ones(2), rng)
    assert out is walkers


def test_a_narrow_mode_of_the_round_before_is_found_again() -> None:
    """A mode 0.02 wide (the analytic density's second one, narrowed) that none of the search's
    own starts reaches is kept when the round before's modes start the search again, as the
    adaptive method passes them (``extra``); without them the search sees one mode."""
    def narrow(theta: np.ndarray) -> np.ndarray:
        theta = np.atleast_2d(theta)
        wide = -0.5 * np.square(theta - CENTRES[0]).sum(-1) / SD**2
        sharp = -0.5 * np.square(theta - CENTRES[1]).sum(-1) / 0.02**2 + np.log(0.3 / 0.7) \
            - 2 * np.log(0.02 / SD)
        return np.where((np.abs(theta) <= 6.0).all(axis=1), np.logaddexp(wide, sharp), -np.inf)

    rng = np.random.default_rng(4)
    walkers = CENTRES[0] + SD * rng.standard_normal((64, 2))
    runs = walkers[:5].copy()  # the best runs lie in the first mode too
    columns = ([0, 1], [0, 1])
    before = CENTRES[1:] + 0.01  # last round's second mode, off by half its width
    _, n_alone, found_alone = modes.spread(narrow, walkers, runs, columns, HARD, PLAUSIBLE,
                                           np.random.default_rng(5), np.zeros((0, 2)))
    spread, n_both, found = modes.spread(narrow, walkers, runs, columns, HARD, PLAUSIBLE,
                                         np.random.default_rng(5), before)
    assert n_alone == 1 and found_alone.shape[0] == 1
    assert n_both == 2
    np.testing.assert_allclose(found[np.argmax(found[:, 0])], CENTRES[1], atol=1e-3)
    # both hold walkers (the new mode's share borrows the first mode's spread, so it is not
    # its mass: the chain's gamma = 1 jumps set the shares, test above)
    assert 0 < int((spread[:, 0] > 0).sum()) < spread.shape[0]

"""The emulator's record of where its posterior reaches past every model run
(:mod:`torchshm.inference.adaptive.final`): the stop rule's extrapolation condition and the
run it asks for."""

from __future__ import annotations

import numpy as np

from torchshm.inference.adaptive.final import beyond_rows, beyond_runs, edge_rows, extrapolation_run


def test_draws_beyond_the_runs_agree_with_the_shares_and_the_run_goes_farthest() -> None:
    rng = np.random.default_rng(3)
    box = np.array([[10.0, 60.0], [0.0, 12.0], [0.0, 5.0]])  # E, log10_k, sigma_a
    runs = np.column_stack([rng.uniform(20.0, 50.0, 10), rng.uniform(0.5, 10.2, 10)])
    draws = np.column_stack([rng.normal(35.0, 1.0, 600), rng.uniform(6.0, 12.0, 600),
                             rng.gamma(20.0, 0.05, 600)])
    beyond = beyond_rows(draws, [0, 1], runs, box)
    hi = runs[:, 1].max()
    assert np.array_equal(beyond, draws[:, 1] > hi + 0.05 * 12.0)  # E's draws lie among the runs
    share = beyond_runs(draws, ["E", "log10_k", "sigma_a"], ["E", "log10_k"], runs, box)
    assert beyond.mean() == share["beyond_runs"]["log10_k"]
    run = extrapolation_run(draws, beyond, [0, 1], runs, box)
    assert run.shape == (1, 3) and run[0, 1] == draws[beyond, 1].max()
    # a draw far past the runs in E wins over one just past them in log10_k
    draws[0] = [59.0, 10.9, 1.0]
    beyond = beyond_rows(draws, [0, 1], runs, box)
    assert np.allclose(extrapolation_run(draws, beyond, [0, 1], runs, box), draws[:1])


def test_draws_at_the_edge_of_the_runs_count_and_the_run_goes_past_it() -> None:
    # a plateau cut where the runs end: the draws pile up within 5 % of the range below the
    # last run (12.3 of the bound 13), none beyond it
    rng = np.random.default_rng(4)
    box = np.array([[15.0, 60.0], [5.0, 13.0]])
    runs = np.column_stack([rng.uniform(21.0, 49.0, 20), np.r_[rng.uniform(6.1, 12.0, 19), 12.3]])
    draws = np.column_stack([rng.normal(33.6, 0.3, 600), np.r_[rng.uniform(10.8, 11.9, 500),
                                                                rng.uniform(11.95, 12.3, 100)]])
    assert not beyond_rows(draws, [0, 1], runs, box).any()
    edge = edge_rows(draws, [0, 1], runs, box)
    assert np.array_equal(edge, draws[:, 1] > 12.3 - 0.05 * 8.0)
    run = extrapolation_run(draws, edge, [0, 1], runs, box)
    assert run[0, 1] == 12.3 + 0.05 * 8.0  # one margin past the last run
    # runs that reach the bound leave nothing to extend on that side
    runs[-1, 1] = 12.9
    assert not edge_rows(draws, [0, 1], runs, box).any()


def test_the_cap_warning_says_which_part_of_the_rule_failed() -> None:
    from torchshm.inference.adaptive.explore import N_SOBOL
    from torchshm.inference.adaptive.final import cap_reason

    def row(runs: int, settled: bool, unresolved: int = 0, edge: bool = False) -> dict:
        return {"n_model_evaluations": float(runs), "settled": float(settled),
                "n_unresolved": float(unresolved), "extrapolating": float(edge)}

    moving = [row(10, False, 300), row(15, True, 200), row(20, False, 100)]
    assert "had not settled" in cap_reason(moving)
    exploring = [row(10, False, 300), row(15, True, 200), row(20, True, 150), row(25, True, 120)]
    text = cap_reason(exploring)
    assert "settled after 15 runs" in text and f"120 of {N_SOBOL} points" in text
    assert "edge" not in text
    assert "edge of the runs" in cap_reason([row(30, True, 0, edge=True)])

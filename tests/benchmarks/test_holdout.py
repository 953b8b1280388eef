"""The held-out cases (``benchmarks/holdout.py``): drawn from a seed, every one a valid problem."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import torch

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from benchmarks.cases import make_problem, truth_vector  # noqa: E402
from benchmarks.catalog import CASES  # noqa: E402
from benchmarks.holdout import HOLDOUT, N_CASES, SEED, generate  # noqa: E402


def _assert_valid(case) -> None:
    """A held-out case is a valid problem: a finite log joint at its truth, and its truths
    inside the plausible box."""
    problem = make_problem(case)
    assert np.isfinite(float(problem.log_joint(truth_vector(case, list(problem.names)))))
    for name, value in case.truth.items():
        low, high = case.priors[name].plausible_bounds
        assert low < value < high


def test_the_same_seed_draws_the_same_cases_and_another_seed_others() -> None:
    again = generate(SEED, N_CASES)
    assert list(again) == list(HOLDOUT)
    assert [(c.truth, c.features, c.kernel, c.sigma_a, c.length) for c in again.values()] == \
        [(c.truth, c.features, c.kernel, c.sigma_a, c.length) for c in HOLDOUT.values()]
    other = generate(SEED + 1, 3)
    assert [c.truth for c in other.values()] != [c.truth for c in list(HOLDOUT.values())[:3]]


def test_held_out_cases_are_new_problems_of_every_dimension() -> None:
    assert not set(HOLDOUT) & set(CASES)
    assert {c.n_physical for c in HOLDOUT.values()} == {2, 3, 4}
    for case in HOLDOUT.values():
        _assert_valid(case)


def test_the_second_set_is_new_and_holds_plates_and_six_parameters() -> None:
    from benchmarks.holdout import FRESH, FRESH_SEED, N_FRESH, generate_fresh

    again = generate_fresh(FRESH_SEED, N_FRESH)
    assert [(c.name, c.truth, c.kernel) for c in again.values()] == [(c.name, c.truth, c.kernel) for c in FRESH.values()]
    assert not set(FRESH) & (set(CASES) | set(HOLDOUT))
    assert {c.n_physical for c in FRESH.values()} == {2, 3, 4, 6}
    assert any(c.model().x.ndim == 2 for c in FRESH.values())  # a plate's field (n x 2)
    for case in FRESH.values():
        _assert_valid(case)


def test_the_third_set_is_new_and_holds_damage_and_five_parameters() -> None:
    from benchmarks.holdout import FRESH, N_THIRD, THIRD, THIRD_SEED, generate_third

    again = generate_third(THIRD_SEED, N_THIRD)
    assert [(c.name, c.truth, c.kernel) for c in again.values()] == [(c.name, c.truth, c.kernel) for c in THIRD.values()]
    assert not set(THIRD) & (set(CASES) | set(HOLDOUT) | set(FRESH))
    assert {c.n_physical for c in THIRD.values()} == {2, 3, 4, 5}
    assert sum("damage" in c.truth for c in THIRD.values()) >= 3  # a localised damage: position and depth
    for case in THIRD.values():
        problem = make_problem(case)
        truth = truth_vector(case, list(problem.names))
        assert np.isfinite(float(problem.log_joint(truth)))
        for name, value in case.truth.items():
            low, high = case.priors[name].plausible_bounds
            assert low < value < high
        if "damage" in case.truth:  # the damage changes the strains: it can be identified at all
            model = case.model()
            at = torch.tensor([case.truth[n] for n in model.names], dtype=torch.float64)
            healthy = at.clone()
            healthy[model.names.index("damage")] = 0.0
            assert float((model(at) - model(healthy)).abs().max()) > 1.0  # µε


def test_the_fourth_set_holds_one_and_seven_or_more_parameters() -> None:
    from benchmarks.holdout import EDGE, EDGE_SEED, FRESH, N_EDGE, THIRD, generate_edge

    again = generate_edge(EDGE_SEED, N_EDGE)
    assert [(c.name, c.truth, c.kernel) for c in again.values()] == [(c.name, c.truth, c.kernel) for c in EDGE.values()]
    assert not set(EDGE) & (set(CASES) | set(HOLDOUT) | set(FRESH) | set(THIRD))
    sizes = {c.n_physical for c in EDGE.values()}
    assert 1 in sizes and max(sizes) >= 8  # dimensions no other set holds
    for case in EDGE.values():
        assert case.name.endswith(f"_p{case.n_physical}")
        problem = make_problem(case)
        assert np.isfinite(float(problem.log_joint(truth_vector(case, list(problem.names)))))
        for name, value in case.truth.items():
            low, high = case.priors[name].plausible_bounds
            assert low < value < high


def test_the_fifth_to_eighth_sets_are_new_draws_of_every_target_dimension() -> None:
    from benchmarks.holdout import (EIGHTH, EIGHTH_SEED, FIFTH, FIFTH_SEED, HELD_OUT, KNOWN, N_EIGHTH, N_FIFTH,
                                    N_SEVENTH, N_SIXTH, SEVENTH, SEVENTH_SEED, SIXTH, SIXTH_SEED, generate_eighth,
                                    generate_fifth, generate_seventh, generate_sixth)

    earlier = set(CASES)
    for cases, again in ((FIFTH, generate_fifth(FIFTH_SEED, N_FIFTH)), (SIXTH, generate_sixth(SIXTH_SEED, N_SIXTH)),
                         (SEVENTH, generate_seventh(SEVENTH_SEED, N_SEVENTH)), (EIGHTH, generate_eighth(EIGHTH_SEED, N_EIGHTH))):
        assert [(c.name, c.truth, c.kernel) for c in again.values()] == [(c.name, c.truth, c.kernel) for c in cases.values()]
        assert not set(cases) & earlier  # no name of an earlier set or of the suite
        earlier |= set(cases)
        assert {2, 3, 4, 6} <= {c.n_physical for c in cases.values()}  # a damage may add one
        assert set(cases) <= set(KNOWN)
    assert HELD_OUT["seventh"] is SEVENTH and HELD_OUT["eighth"] is EIGHTH
    for case in (*SEVENTH.values(), *EIGHTH.values()):
        _assert_valid(case)

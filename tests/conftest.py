"""Shared pytest configuration: float64 by default, fixed seeds, one thread per test process.

Under pytest-xdist (``-n``) each worker process runs on one thread, and so do the programs its
tests start (``OMP_NUM_THREADS`` is inherited): two workers on two cores with two threads each
would spin against each other.

The slow tests (``-m slow``) are handed out first, the documentation's blocks before them and
the few that take a minute or more (:data:`LONGEST`) before those: with ``--dist worksteal`` a long test started last keeps one core busy after the
other has run out of work.
"""

from __future__ import annotations

import os

if os.environ.get("PYTEST_XDIST_WORKER"):
    for _name in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
        os.environ[_name] = "1"

import numpy as np
import pytest
import torch

torch.set_default_dtype(torch.float64)
if os.environ.get("PYTEST_XDIST_WORKER"):
    torch.set_num_threads(1)


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


#: the tests that took a minute or more in CI's durations (2026-11-29), longest first: handed
#: out before every other one, so that none of them starts when the other worker is nearly done
LONGEST = (
    "tests/cli/test_example_plate.py::test_readme_run_identifies_every_parameter_within_its_95_interval",
    "tests/test_docs.py::test_blocks_run_as_written[conf/README.md:136]",
    "tests/likelihood/test_vecchia.py::test_ten_thousand_points_length_of_one_pitch_within_a_tenth_of_a_nat",
    "tests/test_docs.py::test_blocks_run_as_written[docs/parallel.md]",
    "tests/benchmarks/test_suite_smoke.py::test_runner_quick",
)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Run the longest tests first (:data:`LONGEST`, the docs test's blocks, then the other slow
    ones), the rest in their collected order."""

    def rank(item: pytest.Item) -> tuple[int, int]:
        if item.nodeid in LONGEST:
            return 0, LONGEST.index(item.nodeid)
        if item.get_closest_marker("slow") is None:
            return 3, 0
        return (1 if item.nodeid.startswith("tests/test_docs.py::test_blocks_run_as_written") else 2), 0

    items.sort(key=rank)

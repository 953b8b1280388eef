"""Shared pytest configuration: float64 by default, fixed seeds, one thread per test process.

Under pytest-xdist (``-n``) each worker process runs on one thread, and so do the programs its
tests start (``OMP_NUM_THREADS`` is inherited): two workers on two cores with two threads each
would spin against each other.

The slow tests (``-m slow``) are handed out first, the documentation's blocks (the longest)
before them: with ``--dist worksteal`` a long test started last keeps one core busy after the
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


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Run the longest tests first (the docs test's blocks, then the other slow ones), the rest
    in their collected order."""

    def rank(item: pytest.Item) -> int:
        if item.get_closest_marker("slow") is None:
            return 2
        return 0 if item.nodeid.startswith("tests/test_docs.py::test_blocks_run_as_written") else 1

    items.sort(key=rank)

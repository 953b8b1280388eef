"""NumPy's and SciPy's BLAS threads: one during a method's own work, the process's during runs."""

from __future__ import annotations

import pytest
from threadpoolctl import threadpool_info, threadpool_limits

from torchshm.inference import blas


def _blas_threads() -> list[int]:
    return [lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"]


@pytest.fixture
def two_threads():
    if not _blas_threads():
        pytest.skip("no BLAS library that threadpoolctl can set")
    with threadpool_limits(limits=2, user_api="blas"):  # as a 2-core machine has it, in any test worker
        yield


def test_own_work_runs_on_one_thread_and_a_model_run_gets_the_process_threads_back(two_threads) -> None:
    assert set(_blas_threads()) == {2}
    with blas.own_work():
        assert set(_blas_threads()) == {1}
        with blas.model_work():
            assert set(_blas_threads()) == {2}
        assert set(_blas_threads()) == {1}
        with blas.own_work():  # nested (the GP fits inside the emulator's rounds)
            with blas.model_work():
                assert set(_blas_threads()) == {2}
    assert set(_blas_threads()) == {2}


def test_model_work_outside_own_work_changes_nothing(two_threads) -> None:
    with blas.model_work():
        assert set(_blas_threads()) == {2}

"""The VBMC trace is read from PyVBMC's public iteration history, iteration by iteration."""

from __future__ import annotations

import numpy as np
import pyvbmc

from torchshm.inference import variational
from torchshm.inference.tensorboard import RunTrace
from torchshm.inference.variational import IterationTrace


class PointMass:
    """A stand-in variational posterior: every draw is ``value``."""

    def __init__(self, value: float) -> None:
        self.value, self.rng = value, None

    def sample(self, n: int) -> tuple[np.ndarray, None]:
        return np.full((n, 1), self.value), None


class Run:
    """The public part of a ``VBMC`` object the trace reads."""

    def __init__(self) -> None:
        keys = ("vp", "elbo", "elbo_sd", "sKL", "func_count")
        self.iteration_history = {k: None for k in keys}

    def finish(self, it: int, elbo: float) -> None:
        for key, value in zip(("vp", "elbo", "elbo_sd", "sKL", "func_count"),
                              (PointMass(it), elbo, 0.1, None if it == 0 else 0.5, 10 + 5 * it)):
            column = self.iteration_history[key]
            column = np.full(it + 1, None) if column is None else np.append(column, [None])
            column[it] = value
            self.iteration_history[key] = column


def test_each_finished_iteration_is_logged_once_before_the_next_evaluation() -> None:
    trace, run, calls = RunTrace(None, step_key="iteration"), Run(), []
    iterations = IterationTrace(trace, ["a"], n_precomputed=3, seed=0)
    iterations.vbmc = run  # type: ignore[assignment]
    target = iterations.wrap(lambda theta: calls.append(len(trace.history().get("elbo", []))))
    target(np.zeros((1, 1)))  # nothing finished yet
    run.finish(0, -10.0)
    target(np.zeros((1, 1)))  # iteration 0 is logged before this evaluation
    run.finish(1, -9.0)
    iterations.poll()  # after the run: the last iteration
    iterations.poll()  # nothing new
    h = trace.history()
    assert calls == [0, 1]
    np.testing.assert_array_equal(h["iteration"], [0.0, 1.0])
    np.testing.assert_array_equal(h["elbo"], [-10.0, -9.0])
    np.testing.assert_array_equal(h["n_evaluations"], [13.0, 18.0])
    assert np.isnan(h["sKL"][0]) and h["sKL"][1] == 0.5
    np.testing.assert_array_equal(h["a/mean"], [0.0, 1.0])


def test_no_pyvbmc_method_is_overridden() -> None:
    subclasses = [v for v in vars(variational).values()
                  if isinstance(v, type) and issubclass(v, pyvbmc.VBMC) and v is not pyvbmc.VBMC]
    assert subclasses == []

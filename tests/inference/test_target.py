"""The log-joint wrapper: point log, failure handling, known points."""

from __future__ import annotations

import numpy as np
import pytest

from torchshm.inference.target import LogJointTarget, PointLog


class _Quadratic:
    """log_joint = -|theta|^2, NaN where theta[0] > 2 (a failed model run)."""

    names = ["a", "b"]

    def log_joint(self, theta: np.ndarray) -> np.ndarray:
        theta = np.asarray(theta)
        value = -np.sum(theta**2, axis=-1)
        return np.where(theta[..., 0] > 2.0, np.nan, value)


def test_point_log_round_trip_skips_torn_lines_and_other_problems(tmp_path) -> None:
    log = PointLog(tmp_path / "s.points.jsonl", ["a", "b"])
    assert log.read().shape == (0, 2)
    log.append(np.array([[1.0, 2.0], [3.0, 4.0]]))
    log.append(np.array([1.0, 2.0]))  # a repeat is read once
    PointLog(log.path, ["a", "b", "c"]).append(np.ones(3))  # another problem on the same store
    with open(log.path, "a") as fh:
        fh.write('{"names": ["a", "b"], "theta": [5.0')  # torn by a kill
    assert np.array_equal(log.read(), [[1.0, 2.0], [3.0, 4.0]])
    log.append(np.array([[7.0, 8.0]]))  # a new line after the torn one stays readable
    assert np.array_equal(PointLog(log.path, ["a", "b"]).read(), [[1.0, 2.0], [3.0, 4.0], [7.0, 8.0]])


def test_failures_are_imputed_for_vbmc_and_rejected_for_emcee() -> None:
    hard = np.array([[-5.0, 5.0], [-5.0, 5.0]])
    vbmc = LogJointTarget(_Quadratic(), impute_failures=True, hard_bounds=hard)
    assert vbmc(np.array([1.0, 1.0])) == -2.0
    assert vbmc(np.array([0.5, 0.0])) == -0.25
    assert vbmc(np.array([3.0, 0.0])) == -2.0  # lowest finite value seen so far
    assert vbmc.n_failed == 1
    mc = LogJointTarget(_Quadratic(), impute_failures=False, hard_bounds=hard)
    out = mc.evaluate(np.array([[0.0, 0.0], [3.0, 1.0], [6.0, 0.0]]))
    assert out[0] == 0.0 and out[1] == -np.inf and out[2] == -np.inf
    assert mc.n_failed == 1  # (6, 0) is outside the hard bounds: no density, not a failure


def test_first_failure_without_reference_raises() -> None:
    target = LogJointTarget(_Quadratic(), impute_failures=True, hard_bounds=np.array([[-5, 5.0]] * 2))
    with pytest.raises(RuntimeError, match="not finite at any point"):
        target(np.array([3.0, 0.0]))


def test_known_points_are_distinct_finite_and_best_first(tmp_path) -> None:
    log = PointLog(tmp_path / "p.jsonl", ["a", "b"])
    target = LogJointTarget(_Quadratic(), point_log=log)
    target.evaluate(np.array([[1.0, 1.0], [0.0, 0.5], [3.0, 0.0], [1.0, 1.0]]))
    X, y = target.known()
    assert np.array_equal(X, [[0.0, 0.5], [1.0, 1.0]])
    assert np.array_equal(y, [-0.25, -2.0])
    assert log.read().shape == (3, 2)  # every evaluated point is logged, failed ones too


def test_points_of_another_model_are_not_reused(tmp_path: Path) -> None:
    """Reusing another model's points would cost new runs of this model."""
    path = tmp_path / "s.points.jsonl"
    PointLog(path, ["a", "b"], model="surrogate-1").append(np.array([[1.0, 2.0], [3.0, 4.0]]))
    PointLog(path, ["a", "b"], model="fe-1").append(np.array([[5.0, 6.0]]))
    assert np.array_equal(PointLog(path, ["a", "b"], model="fe-1").read(), [[5.0, 6.0]])
    assert np.array_equal(PointLog(path, ["a", "b"], model="surrogate-1").read(), [[1.0, 2.0], [3.0, 4.0]])

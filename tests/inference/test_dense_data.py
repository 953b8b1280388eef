"""VBMC converges on a paper-sized problem: 4 parameters and 3,861 strains (11 load cases x 351
positions at 0.1 m), where the log joint spans ~1e6 nats over the plausible box (the setting of
PyVBMC issue #99). The reference is an independent Laplace approximation of the same log joint.
"""

from __future__ import annotations

import numpy as np
import pytest
from inference_models import beam_problem

from torchshm import identify


def _laplace(problem, centre: np.ndarray, step: np.ndarray) -> tuple[np.ndarray, float]:
    """Covariance `D x D` and log evidence of the Laplace approximation at ``centre``
    (central finite differences with steps ``step``)."""
    dim = centre.size
    f = lambda t: -float(problem.log_joint(t[None])[0])  # noqa: E731
    hess = np.zeros((dim, dim))
    for i in range(dim):
        for j in range(i, dim):
            ei, ej = np.eye(dim)[i] * step[i], np.eye(dim)[j] * step[j]
            hess[i, j] = hess[j, i] = (
                f(centre + ei + ej) - f(centre + ei - ej) - f(centre - ei + ej) + f(centre - ei - ej)
            ) / (4 * step[i] * step[j])
    cov = np.linalg.inv(hess)
    return cov, -f(centre) + 0.5 * np.linalg.slogdet(2 * np.pi * cov)[1]


@pytest.mark.slow
def test_vbmc_converges_on_dense_strain_data() -> None:
    problem = beam_problem()
    assert problem.measurements.y.size == 3861 and len(problem.names) == 4
    post = identify(problem, "vbmc", seed=0, display="off")
    assert post.converged
    assert post.n_model_evaluations <= 50 * (2 + 4)
    s = post.summary()
    mean = np.array([r.mean for r in s.rows])
    sd = np.array([r.sd for r in s.rows])
    cov, log_z = _laplace(problem, mean, 0.5 * sd)
    # near-Gaussian posterior: VBMC's sds within 15 % of the Laplace ones, evidences within 1 nat
    assert np.all(np.abs(sd / np.sqrt(np.diag(cov)) - 1) < 0.15), (sd, np.sqrt(np.diag(cov)))
    assert abs(post.log_evidence - log_z) < 1.0, (post.log_evidence, log_z)
    assert post.log_evidence_sd < 0.5

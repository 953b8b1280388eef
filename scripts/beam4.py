"""A small structure with four physical parameters, for the emulator benchmark.

A 20 m Euler-Bernoulli beam of 40 elements, pinned at both ends with rotational springs: the
left and right halves have moduli ``E1``, ``E2`` [GPa] and the springs stiffnesses
``10**log10_k1``, ``10**log10_k2`` [N·m/rad] (from nearly pinned to nearly fixed over the
prior range, so the response is far from linear in the parameters). A 100 kN axle load at
6, 10 or 14 m (three load cases); the strains [µε] are read at the 40 element midpoints at
0.5 m below the neutral axis. Synthetic data add a Matérn 3/2 discrepancy and noise.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import torch

import torchshm

SPAN, N_EL, INERTIA, DEPTH, FORCE = 20.0, 40, 0.05, 0.5, 1.0e5
TRUTH = (30.0, 42.0, 8.0, 8.7, 0.6, 2.0)


class Beam4:
    """Forward model ``theta_p (..., 4) -> strains (..., 3, 40)`` [µε]."""

    names = ["E1", "E2", "log10_k1", "log10_k2"]
    identity = "beam4-v1"

    def __init__(self) -> None:
        self.h = SPAN / N_EL
        self.x = torch.arange(N_EL, dtype=torch.float64) * self.h + self.h / 2
        self.loads = torch.tensor([6.0, 10.0, 14.0], dtype=torch.float64)

    def __call__(self, theta_p: torch.Tensor) -> torch.Tensor:
        theta = torch.as_tensor(theta_p, dtype=torch.float64)
        flat = theta.reshape(-1, 4)
        h, n_dof = self.h, 2 * (N_EL + 1)
        ke = torch.tensor([[12, 6 * h, -12, 6 * h], [6 * h, 4 * h * h, -6 * h, 2 * h * h],
                           [-12, -6 * h, 12, -6 * h], [6 * h, 2 * h * h, -6 * h, 4 * h * h]],
                          dtype=torch.float64) / h**3
        left = (self.x < SPAN / 2).to(torch.float64)
        ei = 1e9 * INERTIA * (flat[:, :1] * left + flat[:, 1:2] * (1 - left))  # B x N_EL
        k = torch.zeros(flat.shape[0], n_dof, n_dof, dtype=torch.float64)
        for e in range(N_EL):
            k[:, 2 * e:2 * e + 4, 2 * e:2 * e + 4] += ei[:, e, None, None] * ke
        k[:, 1, 1] += 10 ** flat[:, 2]
        k[:, -1, -1] += 10 ** flat[:, 3]
        free = [i for i in range(n_dof) if i not in (0, n_dof - 2)]  # w = 0 at the supports
        kf = k[:, free][:, :, free]
        f = torch.zeros(n_dof, len(self.loads), dtype=torch.float64)
        for j, a in enumerate(self.loads.tolist()):
            f[2 * int(round(a / h)), j] = -FORCE
        u = torch.linalg.solve(kf, f[free].expand(flat.shape[0], -1, -1))  # B x free x 3
        full = torch.zeros(flat.shape[0], n_dof, len(self.loads), dtype=torch.float64)
        full[:, free] = u
        rot = full[:, 1::2]  # B x (N_EL + 1) x 3
        kappa = (rot[:, 1:] - rot[:, :-1]) / h  # curvature at element midpoints
        strain = -1e6 * DEPTH * kappa.transpose(1, 2)  # B x 3 x N_EL
        return strain.reshape(*theta.shape[:-1], len(self.loads), N_EL)


def beam4_priors() -> dict[str, torchshm.Prior]:
    """Priors of the four physical and two statistical parameters."""
    pri = torchshm.paper_priors()
    return {
        "E1": torchshm.Uniform(10.0, 60.0, plausible=(15.0, 55.0)),
        "E2": torchshm.Uniform(10.0, 60.0, plausible=(15.0, 55.0)),
        "log10_k1": torchshm.Uniform(6.0, 11.0, plausible=(6.5, 10.5)),
        "log10_k2": torchshm.Uniform(6.0, 11.0, plausible=(6.5, 10.5)),
        "sigma_a": pri["sigma_a"], "length": pri["length"],
    }


def beam4_problem(store: object = None, seed: int = 0) -> torchshm.Problem:
    """The identification problem on synthetic data from :data:`TRUTH`."""
    model = Beam4()
    rng = np.random.default_rng(seed)
    eta = model(torch.tensor(TRUTH[:4])).numpy()
    cov = torchshm.get_kernel("matern32")(model.x, sigma_a=torch.tensor(TRUTH[4]),
                                          length=torch.tensor(TRUTH[5])).numpy().reshape(N_EL, N_EL)
    chol = np.linalg.cholesky(cov + 1e-9 * np.eye(N_EL))
    y = (eta * (1 + 0.05 * rng.standard_normal(eta.shape))
         + (chol @ rng.standard_normal((N_EL, 3))).T + 0.1 * rng.standard_normal(eta.shape))
    meas = torchshm.Measurements(model.x.numpy(), y, model.loads.numpy(), sigma_e=0.1)
    return torchshm.Problem(model, meas, kernel="matern32", priors=beam4_priors(), store=store)


def beam4_log_joint(problem: torchshm.Problem) -> Callable[[np.ndarray], np.ndarray]:
    """The log joint of ``problem`` computed straight from :class:`Beam4`, without the
    problem's output cache (which would keep every θp of a long chain in memory).

    Returns:
        A function of rows `B x D` (``problem.names`` order) giving `B` log joints, -inf outside
        the prior support; equal to ``problem.log_joint``.
    """
    model = Beam4()
    y = torch.as_tensor(np.asarray(problem.measurements.y, dtype=np.float64))
    x = torch.as_tensor(np.asarray(problem.measurements.x, dtype=np.float64))

    def log_joint(theta: np.ndarray) -> np.ndarray:
        rows = torch.as_tensor(np.atleast_2d(theta), dtype=torch.float64)
        out = problem.prior.log_prob(rows).clone()
        ok = torch.isfinite(out)
        if bool(ok.any()):
            theta_p, sigma_a, length = problem.split.split(rows[ok])
            out[ok] += torchshm.log_likelihood(y, model(theta_p), x, problem.kernel, sigma_a,
                                               length, problem.sigma_m, problem.sigma_e)
        return torch.nan_to_num(out, nan=-torch.inf).numpy()

    return log_joint

"""The jobs that ``scripts/fault_injection.py`` starts, kills and restarts, and their model.

Run as ``python scripts/fault_jobs.py JOB STORE CALL_LOG RESULT [READY]``; ``JOB`` is one of
``vbmc``, ``vbmc1`` (VBMC with seed 1), ``emcee``, ``fit`` (a design fit) or ``emulator``
(when ``torchshm.identify`` has that method). Every job uses one cheap forward model,
:class:`CountingModel`: strains linear in two parameters, a sleep per call (a stand-in for a
long FE run) and one fsynced line per call start and finish in ``CALL_LOG``. At each call
start the model also asks the store whether it already holds that θp; such a call would be a
finished run repeated, and is marked in the log. The problem is linear-Gaussian, so its exact
posterior is known (:func:`exact_posterior`).
"""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

import numpy as np
import torch

import torchshm
from torchshm.storage import theta_key

N_POINTS, LOADS, TRUTH, PRIOR_SD, SIGMA_A, SIGMA_E = 60, (10.0, 20.0), (1.3, -0.7), 1.0, 0.3, 0.1
#: FAULT_SIZE=small (CI): a shorter chain and a smaller design
SMALL = os.environ.get("FAULT_SIZE", "") == "small"
#: emcee settings of the job (walkers, steps, burn-in)
EMCEE = ({"n_walkers": 4, "n_steps": 25, "burn": 5} if SMALL
         else {"n_walkers": 6, "n_steps": 60, "burn": 20})
#: design of the fit job: a grid of the two parameters (5 x 4, small: 3 x 3)
DESIGN = np.array([[a, b] for a in np.linspace(-1.0, 2.0, 3 if SMALL else 5)
                   for b in np.linspace(-2.0, 1.0, 3 if SMALL else 4)])
#: points at which the fitted surrogate is compared with the uninterrupted fit's
TEST_POINTS = np.array([[0.3, -0.2], [1.1, 0.4], [-0.6, -1.3], [1.7, -0.9]])


class CountingModel:
    """``eta = sum_j theta_p[j] * basis[j]`` (`L x n` [µε]) with a call log and a sleep.

    Args:
        log: file receiving ``start <key> <pid> <stored> <time>`` and ``end <key> <pid>
            <time>`` lines, each fsynced; ``stored`` is 1 when the store already held θp.
        store: the evaluation store the job uses (read only here), or None.
        delay: seconds slept per call.
    """

    identity = "fault-injection-linear-v1"

    def __init__(self, log: str | None = None, store: str | None = None, delay: float = 0.02) -> None:
        self.x = torch.arange(N_POINTS, dtype=torch.float64) * 0.1
        self.loads = torch.tensor(LOADS, dtype=torch.float64)
        span = float(self.x[-1]) + 0.1
        self.basis = torch.stack([
            torch.stack([torch.sin((j + 1) * torch.pi * self.x / span + 0.3 * k) * (1 + 0.2 * k)
                         for k in range(len(LOADS))])
            for j in range(2)
        ])  # P x L x n
        self.names = ["p0", "p1"]
        self.log, self.store, self.delay = log, store, float(delay)

    def _write(self, line: str) -> None:
        if self.log is None:
            return
        descriptor = os.open(self.log, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
        try:
            os.write(descriptor, (line + "\n").encode())
            os.fsync(descriptor)
        finally:
            os.close(descriptor)

    def __call__(self, theta_p: torch.Tensor) -> torch.Tensor:
        theta = torch.as_tensor(theta_p, dtype=torch.float64)
        rows = theta.reshape(-1, 2)
        for row in rows:
            key = theta_key(row.numpy())
            stored = 0
            if self.store is not None:
                found = torchshm.EvaluationStore(self.store).lookup(self.identity, [key])
                stored = int(key in found and found[key].ok)
            self._write(f"start {key} {os.getpid()} {stored} {time.time():.6f}")
            time.sleep(self.delay)
            self._write(f"end {key} {os.getpid()} {time.time():.6f}")
        return torch.einsum("...p,pln->...ln", theta, self.basis)


def measurements() -> torchshm.Measurements:
    """Synthetic data of the model at :data:`TRUTH` with independent noise (seed 3)."""
    model = CountingModel()
    eta = np.einsum("p,pln->ln", np.asarray(TRUTH), model.basis.numpy())
    y = eta + np.hypot(SIGMA_A, SIGMA_E) * np.random.default_rng(3).standard_normal(eta.shape)
    return torchshm.Measurements(model.x.numpy(), y, model.loads.numpy(), sigma_e=SIGMA_E)


def problem(model: CountingModel, store: str | None) -> torchshm.Problem:
    """Linear-Gaussian problem: Normal priors, fixed ``sigma_a``, independent errors."""
    priors: dict[str, object] = {name: torchshm.Normal(0.0, PRIOR_SD) for name in model.names}
    priors["sigma_a"] = SIGMA_A
    return torchshm.Problem(model, measurements(), kernel="independent", priors=priors,
                            sigma_m=0.0, store=store)


def exact_posterior() -> tuple[np.ndarray, np.ndarray]:
    """Exact posterior mean `2` and standard deviations `2` of the problem."""
    model, meas = CountingModel(), measurements()
    A = model.basis.numpy().reshape(2, -1).T
    s2 = SIGMA_A**2 + SIGMA_E**2
    cov = np.linalg.inv(np.eye(2) / PRIOR_SD**2 + A.T @ A / s2)
    mean = cov @ (A.T @ np.asarray(meas.y).ravel() / s2)
    return mean, np.sqrt(np.diag(cov))


def run(job: str, store: str, log: str, result: str, ready: str | None = None,
        delay: float = 0.02) -> None:
    """Run one job to the end and write its result (JSON) atomically to ``result``."""
    import torchshm.inference.mcmc  # noqa: F401  (imports done before the job counts as ready)
    import torchshm.inference.variational  # noqa: F401
    import torchshm.surrogate  # noqa: F401

    model = CountingModel(log, store, delay)
    if ready:
        Path(ready).touch()
    out: dict[str, object] = {"job": job}
    if job == "fit":
        sur = torchshm.fit_surrogate(model, DESIGN, store=store, log_inputs=(), modulus=None,
                                     relative_to_modulus=())
        out["prediction"] = sur(torch.as_tensor(TEST_POINTS)).detach().numpy().tolist()
        out["n_design"] = int(sur.theta_p.shape[0])
    else:
        method = "vbmc" if job.startswith("vbmc") else job
        options: dict[str, object] = {"display": "off", "n_samples": 20_000}
        if job == "emcee":
            options = {**EMCEE, "backend_path": f"{store}.emcee.h5"}
        elif job == "emulator":
            options = {}
        post = torchshm.identify(problem(model, store), method, seed=1 if job == "vbmc1" else 0,
                                 **options)
        samples = np.asarray(post.samples)
        out.update(mean=samples.mean(0).tolist(), sd=samples.std(0).tolist(),
                   n_samples=int(samples.shape[0]), converged=bool(post.converged),
                   n_model_evaluations=int(post.n_model_evaluations))
        np.save(result + ".samples.npy", samples)
    temporary = Path(result + ".tmp")
    temporary.write_text(json.dumps(out))
    os.replace(temporary, result)


if __name__ == "__main__":
    arguments = sys.argv[1:]
    delay = float(os.environ.get("FAULT_DELAY", "0.02"))
    run(*arguments[:4], ready=arguments[4] if len(arguments) > 4 else None, delay=delay)

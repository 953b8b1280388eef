"""The cases of the identification suite: structure, truth, data, priors and kernel.

Each :class:`Case` is a complete synthetic identification problem: a cheap forward model
(:mod:`benchmarks.models`), a data-generating truth (model + one draw of the GP discrepancy of
the case's kernel + multiplicative and additive noise, all from the case's seed), the priors and
the kernel the user would write, and the likelihood settings. :func:`make_problem` builds the
:class:`torchshm.Problem`. The cases differ in structure, dimension (2, 3, 4, 6 physical
parameters), kernel, data size, number of load cases and lines, and in the shape of their
posterior (saturating stiffnesses, an unidentified parameter, a ridge, two modes), so that a
method is judged on all of them at once and no single one can be tuned to.

The cases themselves are :data:`benchmarks.catalog.CASES`. :func:`case_hash` is the fingerprint of a case's definition (and of the code that makes its
data); the reference posterior of a case (``benchmarks/references/<name>.json``) records it.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import torch

import torchshm
from benchmarks.models import Beam, BeamSpec, OrthotropicPlate, Role
from torchshm.data.dropouts import with_dropouts

G = torchshm.Gamma
U = torchshm.Uniform


@dataclass
class Case:
    """One identification problem of the suite (see module doc).

    Attributes:
        name: key of the case. features: what it exercises (free text for the tables).
        model: factory of the forward model. truth: physical parameter -> true value.
        sigma_a, length: the discrepancy's true amplitude [µε] and length [m].
        priors: every inferred parameter (physical, ``sigma_a``, ``length``) -> prior.
        kernel: the discrepancy kernel, of the data and of the problem.
        seed: seed of the discrepancy and noise draws.
        data_sigma_m, data_sigma_e: multiplicative and additive noise of the data [-, µε].
        sigma_m: the problem's σm (the user's setting; default 0.05 as in torchshm).
        dropouts: ``(fraction, gap [m])`` of :func:`torchshm.data.with_dropouts`, or None.
        unidentified: parameters the reference leaves out of the accuracy figures.
    """

    name: str
    features: str
    model: Callable[[], Any]
    truth: dict[str, float]
    sigma_a: float
    length: float
    priors: dict[str, Any]
    kernel: str
    seed: int
    data_sigma_m: float = 0.05
    data_sigma_e: float = 0.1
    sigma_m: float = 0.05
    dropouts: tuple[float, float] | None = None
    unidentified: tuple[str, ...] = ()
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def n_physical(self) -> int:
        """`P`, the number of physical parameters."""
        return len(self.truth)


def _gp_draw(kernel: str, x: np.ndarray, sigma_a: float, length: float, rng: np.random.Generator) -> np.ndarray:
    """One draw `n` [µε] of the zero-mean discrepancy GP at positions `n` or coordinates `n x d`."""
    k = torchshm.get_kernel(kernel)
    cov = k(torch.as_tensor(x), sigma_a=torch.tensor(sigma_a, dtype=torch.float64),
            length=torch.tensor(length, dtype=torch.float64)).numpy()
    cov = cov.reshape(len(x), len(x)) + 1e-8 * sigma_a**2 * np.eye(len(x))
    return np.linalg.cholesky(cov) @ rng.standard_normal(len(x))


def make_measurements(case: Case) -> torchshm.Measurements:
    """The case's synthetic campaign: ``η(θ)(1 + σm ε₁) + δ + σe ε₂`` per line and load case.

    ``δ`` is drawn independently for every (line, load case) block, as the likelihood assumes.
    """
    model = case.model()
    rng = np.random.default_rng(case.seed)
    theta = torch.tensor([case.truth[n] for n in model.names], dtype=torch.float64)
    eta = model(theta).numpy()  # L x n
    x = model.x.numpy()
    labels = np.asarray(getattr(model, "line", ["_"] * len(x)))
    y = eta * (1 + case.data_sigma_m * rng.standard_normal(eta.shape))
    for row in y:
        for lab in dict.fromkeys(labels.tolist()):
            part = labels == lab
            row[part] += _gp_draw(case.kernel, x[part], case.sigma_a, case.length, rng)
    y += case.data_sigma_e * rng.standard_normal(eta.shape)
    attrs = {f"truth_{k}": float(v) for k, v in {**case.truth, "sigma_a": case.sigma_a,
                                                 "length": case.length}.items()}
    line = list(model.line) if hasattr(model, "line") else None
    m = torchshm.Measurements(x, y, model.loads.numpy(), sigma_e=case.data_sigma_e, attrs=attrs, line=line)
    if case.dropouts is not None:
        m = with_dropouts(m, fraction=case.dropouts[0], gap=case.dropouts[1], seed=case.seed + 1)
    return m


def make_problem(case: Case, store: Any = None, model: Any = None) -> torchshm.Problem:
    """The :class:`torchshm.Problem` of ``case`` (``model``: a wrapper of ``case.model()``)."""
    priors = dict(case.priors)
    if not torchshm.get_kernel(case.kernel).has_length:
        priors.pop("length", None)
    return torchshm.Problem(model if model is not None else case.model(), make_measurements(case),
                            kernel=case.kernel, priors=priors, sigma_m=case.sigma_m, store=store)


def truth_vector(case: Case, names: list[str]) -> np.ndarray:
    """The true values `D` of the parameters ``names`` (physical, ``sigma_a``, ``length``)."""
    every = {**case.truth, "sigma_a": case.sigma_a, "length": case.length}
    return np.array([every[n] for n in names])


def case_hash(case: Case) -> str:
    """Fingerprint (16 hex digits) of what defines the case's problem: its settings and priors,
    its data (rounded to 1e-4 µε) and its model's strains at the centre of the plausible box
    (so a change of the model's or the data's code shows, a refactoring that keeps them does not)."""
    priors = {k: [repr(p), np.asarray(p.hard_bounds).tolist(), np.asarray(p.plausible_bounds).tolist()]
              for k, p in case.priors.items()}
    model = case.model()
    centre = torch.tensor([float(np.mean(case.priors[n].plausible_bounds)) for n in model.names], dtype=torch.float64)
    digest = hashlib.sha256(np.round(np.nan_to_num(make_measurements(case).y, nan=1e9), 4).tobytes())
    digest.update(np.round(model(centre).numpy(), 4).tobytes())
    text = json.dumps({
        "name": case.name, "model": model.identity, "truth": case.truth, "sigma_a": case.sigma_a,
        "length": case.length, "priors": priors, "kernel": case.kernel, "seed": case.seed,
        "data": [case.data_sigma_m, case.data_sigma_e], "sigma_m": case.sigma_m, "dropouts": case.dropouts,
        "outputs": digest.hexdigest(),
    }, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


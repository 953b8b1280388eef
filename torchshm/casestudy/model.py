"""The forward model of bridge 705: deck bottom-fibre (and optionally top-face) strains under truck T1.

The stiffness of the frame is affine in the two physical parameters,

    K(θ) = E · K0 + K_r · P Pᵀ,

with E = 1000 · E_c [N/mm²], K0 the stiffness at E = 1 N/mm² with hinged pier bases
(nonsingular) and P the `n_free x 6` selection of the pier-base rotations. The loads F and the
strain recovery B do not depend on θ. With κ = K_r / E, the Woodbury identity gives the strains
exactly as

    s(θ) = (1 / E) · [S0 − G (I / κ + H)⁻¹ R],

S0 = B K0⁻¹ F, G = B K0⁻¹ P, H = Pᵀ K0⁻¹ P, R = Pᵀ K0⁻¹ F, computed once at construction. An
evaluation is then a batch of 6 x 6 solves. 1 / κ = E · 10^(−log10 K_r) is formed in log space,
so K_r → ∞ (fixed bases, 1 / κ → 0) and K_r → 0 (hinged bases, 1 / κ → ∞) are both exact limits.
"""

from __future__ import annotations

import dataclasses
import math
from functools import lru_cache

import numpy as np
import torch
from torch import Tensor

from torchshm.forward.protocol import as_tensor
from torchshm.casestudy.config import Bridge705Config
from torchshm.casestudy.frame import reduced_stiffness
from torchshm.casestudy.geometry import BridgeMesh, PierBase, build_mesh
from torchshm.casestudy.priors import paper_priors

#: formulation tag, part of the model identity (change it when the strains would change)
FORMULATION = "frame-woodbury-v1"

#: sensor positions whose strain operator is formed at once (a dense `chunk x n_dof` block)
_SENSOR_CHUNK = 4096

#: largest log(1/κ) used; beyond it the pier springs contribute below double precision
_MAX_LOG_INV_KAPPA = 600.0


def bridge_mesh(
    config: Bridge705Config, E: float = 1.0, pier_base: PierBase = "hinged", K_r: float = 0.0
) -> BridgeMesh:
    """The frame of the model for a modulus `E` [N/mm²] and a pier-base condition."""
    deck, pier = config.deck, config.pier
    return build_mesh(
        deck_x=config.deck_x(),
        deck_EA=E * deck.area,
        deck_EI=E * deck.inertia,
        pier_x=config.pier_x(),
        pier_height=config.pier_height,
        pier_EA=E * pier.area,
        pier_EI=E * pier.inertia,
        pier_elements=config.pier_elements,
        pier_base=pier_base,
        K_r=K_r,
    )


def load_matrix(mesh: BridgeMesh, config: Bridge705Config) -> Tensor:
    """`n_dof x L` nodal forces [N] of the truck at each front-axle position of `config`."""
    columns = [mesh.point_loads(*config.truck.on_deck(front, config.length)) for front in config.loads]
    return torch.stack(columns, dim=1)


#: the deck faces a fibre can run along, and the sign of their distance from the deck axis
FACES = {"bottom": 1.0, "top": -1.0}


@lru_cache(maxsize=8)
def _operators(config: Bridge705Config, face: str = "bottom") -> tuple[Tensor, Tensor, Tensor, Tensor]:
    """S0 (`n x L`), G (`n x 6`), H (`6 x 6`), R (`6 x L`): one K0 solve for the loads and the
    pier-base rotations, strains on the deck ``face``. Cached per configuration and face; the
    tensors are shared, never modified."""
    mesh = bridge_mesh(config)
    free = mesh.frame.free
    position = torch.full((mesh.frame.n_dof,), -1, dtype=torch.int64)
    position[free] = torch.arange(free.numel())
    springs = position[mesh.pier_base_rotations]
    F = load_matrix(mesh, config)[free]
    P = torch.zeros(free.numel(), springs.numel(), dtype=torch.float64)
    P[springs, torch.arange(springs.numel())] = 1.0
    factor = torch.linalg.cholesky(reduced_stiffness(mesh.frame))
    solution = torch.cholesky_solve(torch.cat([F, P], dim=1), factor)
    K0_inv_F, K0_inv_P = solution[:, : F.shape[1]], solution[:, F.shape[1] :]
    sensors, S0, G = config.sensor_x(), [], []
    for start in range(0, sensors.size, _SENSOR_CHUNK):  # bounded memory at dense pitches
        B = mesh.strain_operator(sensors[start : start + _SENSOR_CHUNK], FACES[face] * config.deck.c_b)[:, free]
        S0.append(B @ K0_inv_F)
        G.append(B @ K0_inv_P)
    return torch.cat(S0), torch.cat(G), K0_inv_P[springs], K0_inv_F[springs]


class Bridge705:
    """2-D Euler–Bernoulli frame model of bridge 705 (deck strip on six pier rows).

    Call it with `theta_p` (`... x 2`) = (E_c [GPa], log10 K_r [log10 N·mm/rad]) to get the
    bottom-fibre strains [µε] (`... x L x n`, tension positive) at the fibre positions
    :attr:`x` for every truck position in :attr:`loads`. Batched and differentiable.

    With ``lines=("bottom", "top")`` it gives a second fibre along the top face of the deck at
    the same positions: :attr:`x` then holds the positions of both lines one after the other and
    :attr:`line` their labels (the surrogate of bridge 705 covers the bottom fibre only).

    Attributes:
        x: `n` sensor positions [m] (351 points, 35.0 .. 70.0 m), per line.
        line: `n` line labels (``"bottom"``, ``"top"``), only with a second line.
        loads: `L` front-axle positions [m] of truck T1 (12 load cases).
        names: names of the physical parameters, in input order.
        surrogate_transform: keywords of
            :meth:`torchshm.surrogate.ResponseTransform.fit` that suit this model: every
            stiffness scales with E_c except the pier-base springs, so strains are
            ``g(K_r / E_c) / E_c`` and a surrogate's GP sees log10 E_c, log10 K_r - log10 E_c
            and predicts E_c times the strain (see :mod:`torchshm.surrogate.transforms`).
        identity: stable key of the configuration and formulation.
        config: the configuration.
    """

    names: tuple[str, ...] = ("E_c", "log10_K_r")
    surrogate_transform: dict[str, object] = {
        "log_inputs": (0,), "modulus": 0, "relative_to_modulus": (1,)
    }

    def __init__(self, config: Bridge705Config | None = None, lines: tuple[str, ...] = ("bottom",)) -> None:
        self.config = config or Bridge705Config()
        lines = tuple(lines)
        if not lines or len(set(lines)) != len(lines) or any(f not in FACES for f in lines):
            raise ValueError(f"bridge705: lines must be distinct faces among {list(FACES)}, got {list(lines)}")
        sensors = self.config.sensor_x()
        self.x = torch.as_tensor(np.tile(sensors, len(lines)), dtype=torch.float64)
        self.loads = torch.as_tensor(self.config.loads, dtype=torch.float64)
        self.identity = f"{self.config.identity()}-{FORMULATION}"
        self.S0, self.G, self.H, self.R = _operators(self.config)
        if lines != ("bottom",):
            self.line = np.repeat(np.array(lines), sensors.size)
            self.identity += "-lines-" + "-".join(lines)
            parts = [_operators(self.config, face) for face in lines]
            self.S0, self.G = torch.cat([p[0] for p in parts]), torch.cat([p[1] for p in parts])

    def __call__(self, theta_p: Tensor | np.ndarray) -> Tensor:
        """Strains [µε] `... x L x n` for `theta_p` `... x 2` = (E_c [GPa], log10 K_r)."""
        theta = as_tensor(theta_p)
        if theta.shape[-1] != 2:
            raise ValueError(
                "bridge705: theta_p must end in 2 parameters (E_c, log10_K_r), "
                f"got shape {tuple(theta.shape)}"
            )
        E = 1000.0 * theta[..., 0]
        log_inv_kappa = torch.log(E) - math.log(10.0) * theta[..., 1]
        inv_kappa = torch.exp(torch.clamp(log_inv_kappa, max=_MAX_LOG_INV_KAPPA))
        eye = torch.eye(self.H.shape[0], dtype=torch.float64)
        A = inv_kappa[..., None, None] * eye + self.H
        correction = self.G @ torch.linalg.solve(A, self.R)  # ... x n x L
        strain = (self.S0 - correction) / E[..., None, None]
        return 1e6 * strain.transpose(-1, -2)

    @staticmethod
    def default_priors() -> dict[str, object]:
        """The paper's priors (:func:`~torchshm.casestudy.priors.paper_priors`), which a
        :class:`~torchshm.Problem` of this model uses when given no priors."""
        return paper_priors()

    def __repr__(self) -> str:
        return f"Bridge705({self.loads.numel()} load cases, {self.x.numel()} sensors, {self.identity})"


def bridge705(
    config: Bridge705Config | None = None, pitch: float | None = None, lines: int | tuple[str, ...] = 1
) -> Bridge705:
    """The finite element model of bridge 705 (see :class:`Bridge705`).

    Args:
        config: dimensions, sensors and load cases; defaults to ``Bridge705Config()``.
        pitch: spacing of the fibre sensor points [m] (e.g. 0.005 for about 7,000 points per
            load case); replaces ``config.sensor_pitch``. The strain at each point comes from
            its element's own (Hermite) interpolation, on the same 0.1 m mesh. ``None`` keeps
            the configuration's (0.1 m by default: the model and its identity are unchanged).
        lines: 1 (the bottom fibre), 2 (bottom and top face, line labels ``"bottom"``,
            ``"top"``) or a tuple of faces.

    Raises:
        ValueError: for a pitch that is not a positive number, or unknown lines.
    """
    config = config or Bridge705Config()
    if pitch is not None:
        if not isinstance(pitch, (int, float)) or not math.isfinite(pitch) or pitch <= 0:
            raise ValueError(f"bridge705: pitch must be a positive number of metres, got {pitch!r}")
        config = dataclasses.replace(config, sensor_pitch=float(pitch))
    if lines in (1, 2):
        lines = tuple(FACES)[:lines]  # type: ignore[misc]
    elif isinstance(lines, int) or isinstance(lines, str):
        raise ValueError(f"bridge705: lines must be 1, 2 or a tuple of faces {list(FACES)}, got {lines!r}")
    return Bridge705(config, tuple(lines))

"""The 'true' bridge behind the synthetic campaign: a richer frame than the model.

The synthetic measurements stand in for the paper's unpublished fibre data. They come from a
structure that differs from :class:`~torchshm.casestudy.model.Bridge705` in ways a real deck
does, so that the model discrepancy is physical rather than drawn from a Gaussian process:

- haunches: the deck thickens linearly towards each pier (stiffer, and a larger distance from
  the axis to the bottom fibre);
- flared pier heads: the piers deepen towards the deck, as V-shaped piers do, so they restrain
  the deck's rotation more than the model's prismatic pier;
- pavement and tram-rail zones: stretches with a higher bending stiffness (and a slightly lower
  neutral axis relative to the bottom face);
- smeared cracking around the span centres: stretches of lower bending stiffness (lost tension
  stiffening) with a slightly raised neutral axis;
- cracks in the most strained sagging zones: short zones (decimetres) of reduced stiffness and
  a raised neutral axis, giving local strain peaks;
- wheel prints: each axle load is spread uniformly over a length (print plus dispersion to the
  deck axis) instead of acting at a point;
- the fibre averages the strain over its gauge length (0.2 m) around each reading point;
- a finer mesh (0.025 m) over the fibre and more elements per pier.

Everything else (span lengths, strip width, pier positions and heights, supports, the truck and
the parameters E_c and K_r) is the model's.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import torch
from torch import Tensor

from torchshm.casestudy.config import Bridge705Config
from torchshm.casestudy.frame import bottom_strain, solve
from torchshm.casestudy.geometry import BridgeMesh, build_mesh
from torchshm.casestudy.truck import Truck


@dataclass(frozen=True)
class Zone:
    """A stretch of deck with modified section: factors on EI and on the bottom-fibre distance.

    ``start``/``end`` [m]; for a crack, :class:`Crack` is used instead.
    """

    start: float
    end: float
    stiffness: float
    c_b: float = 1.0


@dataclass(frozen=True)
class Crack:
    """A crack zone centred at ``x`` [m] of total ``width`` [m]: at its centre EI is multiplied
    by ``stiffness`` and the bottom-fibre distance by ``c_b``, with a cos² taper to the edges."""

    x: float
    width: float
    stiffness: float
    c_b: float


@dataclass(frozen=True)
class TruthConfig:
    """Configuration of the truth structure.

    Attributes:
        model: the model configuration it refines (geometry, sensors, load cases, truck).
        E_c: true concrete modulus [GPa].
        log10_K_r: true pier-base rotational stiffness [log10 N·mm/rad].
        fine_pitch: mesh spacing over the fibre [m] (divides the gauge half-length).
        fine_start: start of the fine mesh [m].
        fine_end: end of the fine mesh [m].
        haunch_depth: extra deck thickness at a pier [m].
        haunch_length: length of the linear haunch taper on each side of a pier [m].
        pier_flare: extra pier depth (along the bridge) where the pier meets the deck [m].
        pier_flare_length: length of the linear flare taper down the pier [m].
        pier_elements: frame elements per pier.
        zones: pavement and rail zones (stiffer) and smeared cracking zones (softer).
        cracks: crack zones.
        gauge_length: length over which the fibre averages the strain [m] (0: point values).
        load_spread: length over which each axle load is spread [m] (0: point loads).
    """

    model: Bridge705Config = field(default_factory=Bridge705Config)
    E_c: float = 35.0
    log10_K_r: float = 11.5
    fine_pitch: float = 0.025
    fine_start: float = 34.8
    fine_end: float = 70.2
    haunch_depth: float = 0.04
    haunch_length: float = 2.0
    pier_flare: float = 0.06
    pier_flare_length: float = 1.5
    pier_elements: int = 8
    zones: tuple[Zone, ...] = (
        # pavement and tram-rail stretches: stiffer, neutral axis slightly lower
        Zone(30.0, 38.6, 1.02, 1.01),
        Zone(41.0, 46.4, 1.04, 1.015),
        Zone(55.8, 61.0, 1.035, 1.01),
        Zone(66.2, 75.0, 1.02, 1.005),
        # smeared cracking (lost tension stiffening) around the span centres, in sagging
        Zone(34.0, 39.0, 0.95, 1.015),
        Zone(48.5, 53.5, 0.95, 1.015),
        Zone(63.0, 68.0, 0.95, 1.015),
    )
    cracks: tuple[Crack, ...] = (
        Crack(36.1, 0.3, 0.85, 1.10),
        Crack(37.0, 0.2, 0.88, 1.08),
        Crack(49.3, 0.3, 0.85, 1.10),
        Crack(50.2, 0.4, 0.80, 1.12),
        Crack(51.2, 0.2, 0.88, 1.08),
        Crack(64.4, 0.3, 0.85, 1.10),
        Crack(65.3, 0.4, 0.80, 1.12),
        Crack(66.3, 0.2, 0.88, 1.08),
    )
    gauge_length: float = 0.2
    load_spread: float = 1.0


def deck_sections(config: TruthConfig, deck_x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-element deck area [mm²], inertia [mm⁴] and bottom-fibre distance [mm].

    Properties are taken at each element's midpoint (`n_deck - 1` values each).
    """
    mid = 0.5 * (deck_x[1:] + deck_x[:-1])
    distance = np.min(np.abs(mid[:, None] - config.model.pier_x()[None, :]), axis=1)
    taper = np.clip(1.0 - distance / config.haunch_length, 0.0, None)
    depth = config.model.deck.depth + config.haunch_depth * taper  # m
    width = config.model.deck.width
    area, inertia, c_b = width * depth * 1e6, width * depth**3 / 12.0 * 1e12, depth / 2.0 * 1000.0
    for zone in config.zones:
        inside = (mid >= zone.start) & (mid < zone.end)
        inertia = np.where(inside, inertia * zone.stiffness, inertia)
        c_b = np.where(inside, c_b * zone.c_b, c_b)
    for crack in config.cracks:
        u = np.clip(np.abs(mid - crack.x) / (0.5 * crack.width), 0.0, 1.0)
        shape = np.cos(0.5 * np.pi * u) ** 2
        inertia = inertia * (1.0 - (1.0 - crack.stiffness) * shape)
        c_b = c_b * (1.0 + (crack.c_b - 1.0) * shape)
    return area, inertia, c_b


def pier_sections(config: TruthConfig) -> tuple[np.ndarray, np.ndarray]:
    """Per-element pier area [mm²] and inertia [mm⁴], top element first (flared head)."""
    model = config.model
    n = config.pier_elements
    below_top = (np.arange(n) + 0.5) * model.pier_height / n  # element midpoints [m]
    flare = config.pier_flare * np.clip(1.0 - below_top / config.pier_flare_length, 0.0, None)
    depth = model.pier.depth + flare
    return model.pier.width * depth * 1e6, model.pier.width * depth**3 / 12.0 * 1e12


def truth_mesh(config: TruthConfig) -> tuple[BridgeMesh, np.ndarray]:
    """The truth frame at the true parameters, and its per-element bottom-fibre distance [mm]."""
    model = config.model
    deck_x = model.deck_x(fine=(config.fine_start, config.fine_end, config.fine_pitch))
    area, inertia, c_b = deck_sections(config, deck_x)
    pier_area, pier_inertia = pier_sections(config)
    E = 1000.0 * config.E_c
    mesh = build_mesh(
        deck_x=deck_x,
        deck_EA=E * area,
        deck_EI=E * inertia,
        pier_x=model.pier_x(),
        pier_height=model.pier_height,
        pier_EA=E * pier_area,
        pier_EI=E * pier_inertia,
        pier_elements=config.pier_elements,
        pier_base="spring",
        K_r=10.0**config.log10_K_r,
    )
    return mesh, c_b


def spread_loads(mesh: BridgeMesh, truck: Truck, front: float, length: float, spread: float) -> Tensor:
    """`n_dof` nodal forces [N] of the truck with each axle load spread uniformly over `spread` m.

    The part of a spread load beyond an abutment is lost (it stands on the approach). The load
    on each element goes to its two nodes by the lever rule, so the nodal forces have the
    resultant and the first moment of the spread load. ``spread <= 0`` gives point loads.
    """
    if spread <= 0.0:
        return mesh.point_loads(*truck.on_deck(front, length))
    x = mesh.deck_x
    positions, forces = truck.axles(front)
    nodal = np.zeros(x.size)
    for position, force in zip(positions, forces):
        lo = np.clip(x[:-1], position - spread / 2, position + spread / 2)
        hi = np.clip(x[1:], position - spread / 2, position + spread / 2)
        share = force * (hi - lo) / spread  # load on each element [N]
        to_end = (0.5 * (lo + hi) - x[:-1]) / np.diff(x)
        nodal[:-1] += share * (1.0 - to_end)
        nodal[1:] += share * to_end
    return mesh.point_loads(x, nodal)


def gauge_weights(deck_x: np.ndarray, sensor_x: np.ndarray, gauge: float) -> np.ndarray:
    """`n x (n_deck - 1)` weights averaging element-midpoint strains over each gauge.

    The strain is linear within an element, so its mean over an element is the midpoint value;
    gauge ends must fall on nodes (checked).
    """
    mid = 0.5 * (deck_x[1:] + deck_x[:-1])
    length = np.diff(deck_x)
    inside = np.abs(mid[None, :] - sensor_x[:, None]) < gauge / 2
    covered = inside.astype(np.float64) @ length
    if np.max(np.abs(covered - gauge)) > 1e-6:
        raise ValueError("truth: gauge ends do not fall on mesh nodes; refine or align the fine mesh")
    return inside * length[None, :] / gauge


def truth_strains(config: TruthConfig | None = None) -> Tensor:
    """Noise-free, gauge-averaged bottom-fibre strains [µε] of the truth structure.

    Returns:
        `L x n` strains for the model's load cases and sensor positions.
    """
    config = config or TruthConfig()
    model = config.model
    mesh, c_b = truth_mesh(config)
    F = torch.stack(
        [spread_loads(mesh, model.truck, front, model.length, config.load_spread) for front in model.loads],
        dim=1,
    )
    U = solve(mesh.frame, F)
    if config.gauge_length <= 0.0:
        return 1e6 * (mesh.strain_operator(model.sensor_x(), c_b) @ U).T
    if not gauge_on_nodes(mesh.deck_x, model.sensor_x(), config.gauge_length):
        return 1e6 * gauge_average(mesh, U, c_b, model.sensor_x(), config.gauge_length).T
    n_el = mesh.deck_x.size - 1
    element = torch.arange(n_el)
    mid_strain = bottom_strain(mesh.frame, U, element, torch.full((n_el,), 0.5), torch.as_tensor(c_b))
    W = torch.as_tensor(gauge_weights(mesh.deck_x, model.sensor_x(), config.gauge_length))
    return 1e6 * (W @ mid_strain).T


def gauge_on_nodes(deck_x: np.ndarray, sensor_x: np.ndarray, gauge: float) -> bool:
    """Whether both ends of every gauge fall on mesh nodes (to 1e-6 m)."""
    ends = np.concatenate([sensor_x - gauge / 2, sensor_x + gauge / 2])
    index = np.clip(np.searchsorted(deck_x, ends), 1, deck_x.size - 1)
    gap = np.minimum(np.abs(deck_x[index] - ends), np.abs(deck_x[index - 1] - ends))
    return bool(np.all(gap <= 1e-6))


def gauge_average(mesh: BridgeMesh, U: Tensor, c_b: np.ndarray, sensor_x: np.ndarray, gauge: float) -> Tensor:
    """Bottom-fibre strain `n x k` averaged over a gauge around each of `n` sensor positions [m],
    for gauges whose ends fall anywhere (any sensor pitch).

    The strain is linear within an element, so its integral over the part of an element inside
    the gauge is that part's length times the strain at its midpoint: the average is exact.
    """
    x = mesh.deck_x
    lo, hi = sensor_x - gauge / 2, sensor_x + gauge / 2
    first = np.clip(np.searchsorted(x, lo, side="right") - 1, 0, x.size - 2)
    span = int(np.max(np.searchsorted(x, hi, side="left") - first)) + 1
    element = np.minimum(first[:, None] + np.arange(span)[None, :], x.size - 2)  # n x span
    start = np.maximum(x[element], lo[:, None])
    end = np.minimum(x[element + 1], hi[:, None])
    inside = np.clip(end - start, 0.0, None)
    inside[:, 1:] *= element[:, 1:] != element[:, :-1]  # an element counted once
    xi = (0.5 * (start + end) - x[element]) / (x[element + 1] - x[element])
    strain = bottom_strain(
        mesh.frame,
        U,
        torch.as_tensor(element.ravel()),
        torch.as_tensor(np.clip(xi, 0.0, 1.0).ravel()),
        torch.as_tensor(c_b[element.ravel()]),
    )
    weights = torch.as_tensor(inside / gauge).reshape(-1, 1)
    return (strain * weights).reshape(*element.shape, -1).sum(1)

"""Dimensions of the 2-D model of bridge 705: deck strip, piers, sensors, load cases.

The deck is 102 m long on seven equal spans (piers at 102·k/7 m). The 2-D model represents the
strip of deck under the lane of truck T1 that carries its load, with an effective width and a
uniform thickness, and the share of the V-shaped piers under that strip as one vertical leg per
pier row. Values are documented with their reasons in ``docs/bridge705.md``.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, field

import numpy as np

from torchshm.casestudy.truck import T1, T1_POSITIONS, Truck


@dataclass(frozen=True)
class Rectangle:
    """A rectangular cross-section.

    Attributes:
        width: out-of-plane width [m].
        depth: in-plane depth [m] (deck thickness; pier dimension along the bridge).
    """

    width: float
    depth: float

    @property
    def area(self) -> float:
        """Area [mm²]."""
        return self.width * self.depth * 1e6

    @property
    def inertia(self) -> float:
        """Second moment of area about the centroidal axis [mm⁴]."""
        return self.width * self.depth**3 / 12.0 * 1e12

    @property
    def c_b(self) -> float:
        """Distance from the centroid to the bottom fibre [mm]."""
        return self.depth / 2.0 * 1000.0


@dataclass(frozen=True)
class Bridge705Config:
    """Configuration of the 2-D frame model of bridge 705.

    Attributes:
        length: deck length between the abutments [m].
        n_spans: number of spans (piers at ``length * k / n_spans``, k = 1 .. n_spans - 1).
        deck: effective deck strip section.
        pier: effective pier section per pier row under the strip.
        pier_height: pier length from the deck axis to the pier base [m].
        pier_elements: frame elements per pier.
        pitch: deck mesh spacing [m] (sensor points and axle positions fall on nodes).
        sensor_start: first fibre sensor point [m].
        sensor_end: last fibre sensor point [m].
        sensor_pitch: spacing of the fibre sensor points [m].
        loads: front-axle positions of the load cases [m].
        truck: the truck.
    """

    length: float = 102.0
    n_spans: int = 7
    deck: Rectangle = Rectangle(width=4.0, depth=0.6)
    pier: Rectangle = Rectangle(width=1.0, depth=0.6)
    pier_height: float = 4.0
    pier_elements: int = 4
    pitch: float = 0.1
    sensor_start: float = 35.0
    sensor_end: float = 70.0
    sensor_pitch: float = 0.1
    loads: tuple[float, ...] = T1_POSITIONS
    truck: Truck = field(default_factory=lambda: T1)

    def __post_init__(self) -> None:
        object.__setattr__(self, "loads", tuple(float(v) for v in self.loads))

    def pier_x(self) -> np.ndarray:
        """Pier positions [m], (`n_spans - 1`,)."""
        return self.length * np.arange(1, self.n_spans) / self.n_spans

    def sensor_x(self) -> np.ndarray:
        """Fibre sensor positions [m], (`n`,), rounded to 1e-9 m."""
        n = int(round((self.sensor_end - self.sensor_start) / self.sensor_pitch)) + 1
        return np.round(self.sensor_start + self.sensor_pitch * np.arange(n), 9)

    def deck_x(
        self, pitch: float | None = None, fine: tuple[float, float, float] | None = None
    ) -> np.ndarray:
        """Deck node positions [m]: a regular grid, the pier positions and the abutments.

        Args:
            pitch: grid spacing [m]; defaults to :attr:`pitch`.
            fine: optional ``(start, end, pitch)`` of a finer grid over part of the deck [m].
        """
        pitch = self.pitch if pitch is None else pitch
        n = int(round(self.length / pitch))
        parts = [pitch * np.arange(n + 1), self.pier_x()]
        if fine is not None:
            start, end, step = fine
            parts.append(start + step * np.arange(int(round((end - start) / step)) + 1))
        x = np.round(np.concatenate(parts), 9)
        return np.unique(x[(x >= 0.0) & (x <= self.length)])

    def identity(self) -> str:
        """Stable hash of the configuration, ``bridge705-<16 hex digits>``."""
        text = json.dumps(asdict(self), sort_keys=True)
        return "bridge705-" + hashlib.sha256(text.encode()).hexdigest()[:16]

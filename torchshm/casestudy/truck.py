"""The load-test truck T1 and its axle loads on the deck.

Truck T1 of the 2018 campaign has four axles and a mass of 34.95 t. Axle masses and spacings
were not published; the values below (two steering axles and a tandem, spacings on a 0.1 m
grid so that every axle falls on a deck node) are this library's choice and are documented in
``docs/bridge705.md``. The truck drives in +x: the front axle is at the largest x and the other
axles trail behind it, at ``front - offset``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: standard gravity [m/s²]
GRAVITY = 9.81

#: the twelve front-axle positions of load series T1 [m], from the left abutment (paper, Fig. 2)
T1_POSITIONS: tuple[float, ...] = (
    10.5, 16.9, 24.5, 32.2, 39.8, 47.5, 55.1, 62.8, 70.4, 78.1, 85.7, 99.9,
)


@dataclass(frozen=True)
class Truck:
    """A truck as a set of axles.

    Attributes:
        masses: mass carried by each axle [t], front axle first.
        offsets: distance of each axle behind the front axle [m] (0 for the front axle).
    """

    masses: tuple[float, ...] = (7.5, 7.5, 9.975, 9.975)
    offsets: tuple[float, ...] = (0.0, 1.9, 5.1, 6.5)

    def __post_init__(self) -> None:
        object.__setattr__(self, "masses", tuple(float(v) for v in self.masses))
        object.__setattr__(self, "offsets", tuple(float(v) for v in self.offsets))
        if len(self.masses) != len(self.offsets):
            raise ValueError("truck: masses and offsets must have the same length")

    @property
    def total_mass(self) -> float:
        """Mass of the truck [t]."""
        return float(sum(self.masses))

    def axles(self, front: float) -> tuple[np.ndarray, np.ndarray]:
        """Axle positions [m] and axle forces [N] (downwards) for a front-axle position.

        Args:
            front: front-axle position along the bridge [m].

        Returns:
            positions (`A`,) [m] and forces (`A`,) [N], in axle order, off-deck axles included.
        """
        positions = np.round(front - np.asarray(self.offsets, dtype=np.float64), 9)
        forces = np.asarray(self.masses, dtype=np.float64) * 1000.0 * GRAVITY
        return positions, forces

    def on_deck(self, front: float, deck_length: float) -> tuple[np.ndarray, np.ndarray]:
        """Like :meth:`axles`, keeping only axles on the deck, ``0 <= x <= deck_length``.

        An axle beyond an abutment stands on the approach, not on the bridge: it carries
        nothing to the deck.
        """
        positions, forces = self.axles(front)
        keep = (positions >= 0.0) & (positions <= deck_length)
        return positions[keep], forces[keep]


#: truck T1 of the load test (34.95 t)
T1 = Truck()

"""The 2-D frame finite element model of bridge 705 and the truth structure behind the
synthetic campaign (see ``docs/bridge705.md``)."""

from __future__ import annotations

from torchshm.physics.bridge705 import Bridge705, bridge705
from torchshm.physics.config import Bridge705Config, Rectangle
from torchshm.physics.frame import Frame
from torchshm.physics.truck import T1, T1_POSITIONS, Truck
from torchshm.physics.truth import TruthConfig, truth_strains

__all__ = [
    "Bridge705",
    "Bridge705Config",
    "Frame",
    "Rectangle",
    "T1",
    "T1_POSITIONS",
    "Truck",
    "TruthConfig",
    "bridge705",
    "truth_strains",
]

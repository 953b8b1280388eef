"""FE-efficient identification (``method="emulator"``): an adaptive field emulator of the model
over the physical parameters, refined in concurrent batches of model runs chosen for the
posterior. See ``docs/inference.md``."""

from __future__ import annotations

from torchshm.inference.adaptive.method import run_emulator

__all__ = ["run_emulator"]

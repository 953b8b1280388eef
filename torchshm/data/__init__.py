"""Strain measurements: the container, its file formats, dropouts and anomaly flags."""

from __future__ import annotations

from typing import Any

from torchshm.data.loading import load_measurements
from torchshm.data.measurements import Measurements

__all__ = ["Measurements", "load_measurements", "flag_anomalies", "with_dropouts"]


def __getattr__(name: str) -> Any:
    if name == "flag_anomalies":
        from torchshm.data.anomaly import flag_anomalies

        return flag_anomalies
    if name == "with_dropouts":
        from torchshm.data.dropouts import with_dropouts

        return with_dropouts
    raise AttributeError(f"module 'torchshm.data' has no attribute {name!r}")

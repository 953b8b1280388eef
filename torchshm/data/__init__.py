"""Measurements and the shipped synthetic campaign of bridge 705."""

from __future__ import annotations

from typing import Any

from torchshm.data.measurements import Measurements, load_measurements

__all__ = ["Measurements", "load_measurements", "synthetic_campaign", "flag_anomalies", "with_dropouts"]


def __getattr__(name: str) -> Any:
    if name == "flag_anomalies":
        from torchshm.data.anomaly import flag_anomalies

        return flag_anomalies
    if name == "synthetic_campaign":
        from torchshm.data.campaign import synthetic_campaign

        return synthetic_campaign
    if name == "with_dropouts":
        from torchshm.data.dropouts import with_dropouts

        return with_dropouts
    raise AttributeError(f"module 'torchshm.data' has no attribute {name!r}")

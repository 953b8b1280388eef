"""Measurements and the shipped synthetic campaign of bridge 705."""

from __future__ import annotations

from typing import Any

from torchshm.data.measurements import Measurements, load_measurements

__all__ = ["Measurements", "load_measurements", "synthetic_campaign", "flag_anomalies", "with_dropouts"]


def __getattr__(name: str) -> Any:
    if name == "flag_anomalies":
        from torchshm.data.anomaly import flag_anomalies

        return flag_anomalies
    if name in ("synthetic_campaign", "with_dropouts"):
        from torchshm.data import campaign

        return getattr(campaign, name)
    raise AttributeError(f"module 'torchshm.data' has no attribute {name!r}")

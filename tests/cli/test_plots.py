"""The figures of a run: the corner plot names the posterior's warnings in a red title."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from torchshm.cli import plots


def _title_texts(monkeypatch) -> list[tuple[str, str]]:  # type: ignore[no-untyped-def]
    """Records (text, colour) of every figure text drawn by the plots."""
    import matplotlib.figure

    seen: list[tuple[str, str]] = []
    original = matplotlib.figure.Figure.text

    def text(self, x, y, s, *args, **kwargs):  # type: ignore[no-untyped-def]
        seen.append((s, kwargs.get("color", "")))
        return original(self, x, y, s, *args, **kwargs)

    monkeypatch.setattr(matplotlib.figure.Figure, "text", text)
    return seen


def test_corner_plot_has_a_red_title_only_with_warnings(tmp_path: Path, monkeypatch) -> None:
    seen = _title_texts(monkeypatch)
    samples = np.random.default_rng(0).normal(size=(500, 2))
    plots.corner_plot({"vbmc": samples}, ["a", "b"], tmp_path / "clean.png")
    assert seen == [] and (tmp_path / "clean.png").is_file()
    warnings = ["NOT CONVERGED: VBMC stopped ...", "NOISE MODEL: whitened residuals ..."]
    plots.corner_plot({"vbmc": samples}, ["a", "b"], tmp_path / "flagged.png", warnings=warnings)
    assert seen == [("WARNING: NOT CONVERGED; NOISE MODEL", "red")]

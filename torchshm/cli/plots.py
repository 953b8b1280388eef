"""Figures of a run: corner plot, ELBO trace, convergence traces, held-out predictions (one
panel per sensor line, or maps of a 2-D field).

Every function draws on a fresh figure with the non-interactive Agg backend, saves it to
``path`` and closes it, so the functions can run headless and in parallel jobs. Parameter axes
are labelled by ``labels`` (name -> text, e.g. from the priors' ``label`` and ``unit``, see
:func:`torchshm.config.parameter_labels`), else by the parameter names.
"""

from __future__ import annotations

from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

#: colours of overlaid posteriors (matplotlib's default cycle)
COLOURS = ("C0", "C1", "C2", "C3")


def _pyplot():  # type: ignore[no-untyped-def]
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def corner_plot(
    samples: Mapping[str, np.ndarray], names: Sequence[str], path: Path,
    truths: Mapping[str, float] | None = None, max_points: int = 20_000,
    labels: Mapping[str, str] | None = None, warnings: Sequence[str] = (),
) -> Path:
    """1-D and 2-D marginals of one or more posteriors, overlaid (paper, Fig. 4).

    Args:
        samples: label -> `S x D` samples (columns in the order of ``names``).
        names: the `D` parameter names.
        path: the PNG file.
        truths: name -> true value, marked with lines where known.
        max_points: at most this many samples of each posterior are drawn (evenly thinned).
        labels: axis label per name (default: the name).
        warnings: the posterior's warning lines; their tags (``NOT CONVERGED``, ``PRIOR BOUND
            (E_c upper)``, ...) become a red title.
    """
    import corner

    plt = _pyplot()
    fig = None
    handles = []
    truth_row = [None if truths is None else truths.get(n) for n in names]
    ranges = _common_ranges(list(samples.values()), truth_row)
    for i, (label, s) in enumerate(samples.items()):
        s = np.asarray(s, dtype=np.float64)
        s = s[:: max(1, s.shape[0] // max_points)]
        colour = COLOURS[i % len(COLOURS)]
        fig = corner.corner(
            s, fig=fig, labels=[(labels or {}).get(n, n) for n in names], range=ranges, color=colour,
            truths=truth_row if i == 0 and any(t is not None for t in truth_row) else None,
            truth_color="k", plot_datapoints=False, plot_density=False, fill_contours=False,
            levels=(0.393, 0.865), smooth=1.0, hist_kwargs={"density": True},
        )
        handles.append(plt.Line2D([], [], color=colour, label=label))
    if truths and any(t is not None for t in truth_row):
        handles.append(plt.Line2D([], [], color="k", label="truth"))
    fig.legend(handles=handles, loc="upper right", frameon=False)
    _warning_title(fig, warnings)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _warning_title(fig: object, warnings: Sequence[str]) -> None:
    """A red title naming the warnings, top left above the plots (nothing without warnings)."""
    from textwrap import fill

    from torchshm.inference.checks import warning_tags

    tags = warning_tags(list(warnings))
    if tags:
        fig.text(0.02, 0.995, fill(f"WARNING: {tags}", 70), color="red", fontsize="large",  # type: ignore[attr-defined]
                 fontweight="bold", ha="left", va="top")


def _common_ranges(sets: list[np.ndarray], truths: Sequence[float | None]) -> list[tuple[float, float]]:
    """Per-column plotting range covering the 0.1 %-99.9 % quantiles of every set and the truth."""
    lo = np.min([np.quantile(s, 0.001, axis=0) for s in sets], axis=0)
    hi = np.max([np.quantile(s, 0.999, axis=0) for s in sets], axis=0)
    for i, t in enumerate(truths):
        if t is not None:
            lo[i], hi[i] = min(lo[i], t), max(hi[i], t)
    pad = 0.05 * np.maximum(hi - lo, 1e-12)
    return [(float(a - p), float(b + p)) for a, b, p in zip(lo, hi, pad)]


def elbo_plot(history: Mapping[str, np.ndarray], path: Path) -> Path:
    """ELBO (± 2 sd) per VBMC iteration against the number of evaluations."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6, 3.5), constrained_layout=True)
    x = np.asarray(history["n_evaluations"])
    elbo = np.asarray(history["elbo"])
    sd = np.asarray(history.get("elbo_sd", np.zeros_like(elbo)))
    ax.plot(x, elbo, "o-", ms=3, color="C0", label="ELBO")
    ax.fill_between(x, elbo - 2 * sd, elbo + 2 * sd, color="C0", alpha=0.25, label="± 2 sd")
    ax.set_xlabel("log-joint evaluations")
    ax.set_ylabel("ELBO [nats]")
    finite = elbo[np.isfinite(elbo)]
    if finite.size > 3:  # early iterations can be far off: show the settled part
        ax.set_ylim(np.quantile(finite, 0.2) - 5 * (np.ptp(finite[-3:]) + 1), finite.max() + 3)
    ax.legend(frameon=False)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def trace_plot(
    x: np.ndarray, traces: Mapping[str, tuple[np.ndarray, np.ndarray, np.ndarray]],
    path: Path, xlabel: str, title: str = "", marks: Mapping[str, float] | None = None,
    labels: Mapping[str, str] | None = None,
) -> Path:
    """Mean and 95 % interval of each parameter against evaluations (paper, Figs. 5 and 6).

    Args:
        x: `T` abscissae (evaluations or samples).
        traces: name -> (mean, lower, upper), each of length `T`.
        path: the PNG file.
        xlabel: label of the abscissa.
        title: figure title.
        marks: label -> abscissa of a vertical dashed line (e.g. convergence).
        labels: axis label per name (default: the name).
    """
    plt = _pyplot()
    names = list(traces)
    fig, axes = plt.subplots(len(names), 1, figsize=(6.5, 1.9 * len(names) + 0.6), sharex=True,
                             constrained_layout=True)
    for ax, name in zip(np.atleast_1d(axes), names):
        mean, lower, upper = (np.asarray(a) for a in traces[name])
        ax.plot(x, mean, color="C0", lw=1.2)
        ax.fill_between(x, lower, upper, color="C0", alpha=0.3, lw=0)
        ax.set_ylabel((labels or {}).get(name, name))
        for j, (label, at) in enumerate((marks or {}).items()):
            ax.axvline(at, color=COLOURS[(j + 1) % len(COLOURS)], ls="--", lw=1, label=label)
    np.atleast_1d(axes)[-1].set_xlabel(xlabel)
    if marks:
        np.atleast_1d(axes)[0].legend(frameon=False, fontsize="small")
    if title:
        fig.suptitle(title)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def predictive_plot(pred: object, measurements: object, path: Path) -> Path:
    """Held-out measurements against the posterior predictive mean and interval (Figs. 9-10):
    one row per load case, one panel per sensor line (positions along the line)."""
    plt = _pyplot()
    loads = [float(v) for v in pred.loads]  # type: ignore[attr-defined]
    lines = list(pred.lines)  # type: ignore[attr-defined]
    fig, axes = plt.subplots(len(loads), len(lines), figsize=(8 * len(lines) ** 0.5, 2.2 * len(loads) + 0.4),
                             sharex="col", squeeze=False, constrained_layout=True)
    for row, load in enumerate(loads):
        i = pred.select(load)  # type: ignore[attr-defined]
        y = measurements.select([load])  # type: ignore[attr-defined]
        for col, line in enumerate(lines):
            ax = axes[row, col]
            points = pred.points_of(line)  # type: ignore[attr-defined]
            mine = slice(None) if line is None else y.line_slices().get(_label(y, line), slice(0, 0))
            ax.plot(y.x[mine], y.y[0, mine], ".", ms=2, color="C1", label="measured")
            x = np.asarray(pred.x)[points]  # type: ignore[attr-defined]
            ax.plot(x, np.asarray(pred.mean[i])[points], color="C0", lw=1, label="predictive mean")  # type: ignore[attr-defined]
            ax.fill_between(x, np.asarray(pred.lower[i])[points], np.asarray(pred.upper[i])[points],  # type: ignore[attr-defined]
                            color="C0", alpha=0.3, lw=0, label="95 % interval")
            if col == 0:
                ax.set_ylabel(f"strain [µε]\nload {load:g} m")
            if row == 0 and line is not None:
                ax.set_title(f"line {line}")
    axes[0, 0].legend(frameon=False, fontsize="small", ncol=3)
    for ax in axes[-1]:
        ax.set_xlabel("x [m]")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _label(measurements: object, line: str) -> object:
    """The measurements' own label (int or str) of the prediction's line label (text)."""
    return next((v for v in measurements.lines if str(v) == str(line)), line)  # type: ignore[attr-defined]


#: total marker area [pt²] of a map's points (60 pt² squares up to 192 points, the plate example's
#: grid; smaller ones for more points, down to MARKER_SMALLEST, so a camera field does not blot)
MARKER_AREA, MARKER_SMALLEST = 60.0 * 192, 0.3
#: share of the points at each end of a map's colour range left out of it (drawn in the end colours)
CLIP = 0.001


def predictive_map(pred: object, measurements: object, load: float, path: Path) -> Path:
    """A held-out load case of a field (`n x 2` coordinates): four maps of the points.

    Measured strain and predictive mean (one colour scale, without the :data:`CLIP` extremes of
    either end when there are more than ``1 / CLIP`` values), the width of the interval, and
    where the measurement falls outside it (red above, blue below; grey inside).
    """
    plt = _pyplot()
    from torchshm.data.positions import match_on_lines
    from torchshm.predictive.metrics import aligned

    y = measurements.select([load])  # type: ignore[attr-defined]
    values, mean, lower, upper = (a[0] for a in aligned(pred, y, [load]))  # type: ignore[arg-type]
    _, found = match_on_lines(y.x, y.line, np.asarray(pred.x), pred.line)  # type: ignore[attr-defined]
    xy = np.asarray(y.x)[found]  # the points aligned() compares, in its order
    valid = np.isfinite(values)
    above, below = valid & (values > upper), valid & (values < lower)
    both = np.concatenate([values[valid], np.asarray(mean)])  # colour range: all but the 0.1 % extremes
    low, high = np.quantile(both, [CLIP, 1.0 - CLIP]) if len(both) > 1 / CLIP else (both.min(), both.max())
    fig, axes = plt.subplots(2, 2, figsize=(10, 7.5), sharex=True, sharey=True, constrained_layout=True)
    size = float(np.clip(MARKER_AREA / max(len(xy), 1), MARKER_SMALLEST, 60.0))  # squares that tile the panel
    panels = (("measured [µε]", values, "viridis", (low, high)), ("predictive mean [µε]", mean, "viridis", (low, high)),
              ("95 % interval width [µε]", upper - lower, "magma", (None, None)))
    for ax, (title, v, cmap, (vmin, vmax)) in zip(axes.flat, panels):
        shown = np.isfinite(v)
        art = ax.scatter(xy[shown, 0], xy[shown, 1], c=v[shown], cmap=cmap, vmin=vmin, vmax=vmax, marker="s", s=size,
                         linewidths=0, rasterized=True)
        fig.colorbar(art, ax=ax, shrink=0.85, extend="neither" if vmin is None else "both")
        ax.set_title(title)
    ax = axes[1, 1]
    for where, colour, label in ((slice(None), "0.85", "inside"), (above, "C3", "above"), (below, "C0", "below")):
        ax.scatter(xy[where, 0], xy[where, 1], c=colour, marker="s", s=size if label == "inside" else max(size, 2.0),
                   linewidths=0, rasterized=True, label=label)
    ax.set_title(f"outside the interval: {int(above.sum() + below.sum())} of {int(valid.sum())}")
    ax.legend(frameon=False, fontsize="small", loc="upper left", bbox_to_anchor=(1.0, 1.0),
              markerscale=max(1.0, (30.0 / size) ** 0.5))
    for ax in axes.flat:
        ax.set_aspect("equal")
    for ax in axes[-1]:
        ax.set_xlabel("x [m]")
    for ax in axes[:, 0]:
        ax.set_ylabel("y [m]")
    fig.suptitle(f"held-out load {load:g} m: measured and posterior predictive")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


__all__ = ["corner_plot", "elbo_plot", "predictive_map", "predictive_plot", "trace_plot"]

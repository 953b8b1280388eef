"""A :class:`~torchshm.inference.Posterior` as one netCDF file with InferenceData-style groups (xarray, h5netcdf).

Groups:

- ``posterior``: one variable per parameter, dims ``(chain, draw)``; attributes: method, names,
  convergence, evidence, model evaluations, priors (JSON), diagnostics (JSON) and warnings
  (JSON list of lines; a file written before warnings existed reads as none).
- ``sample_stats``: per-sample statistics, dims ``(chain, draw)`` (emcee: ``lp``).
- ``observed_data``: the measurements of the problem, ``y`` with dims ``(load, x)`` (for `n x d`
  coordinates: ``y(load, point)`` and ``x(point, axis)``).
- ``history``: the per-iteration trace, one variable ``value`` with dims ``(row, column)``.
- ``variational_posterior`` (VBMC): the mixture (``w``, ``mu``, ``sigma``, ``lambd``) and the
  state of PyVBMC's parameter transformer, from which
  :func:`~torchshm.inference.netcdf_load.load_posterior` rebuilds a
  ``VariationalPosterior`` whose ``pdf`` and ``sample`` are those of the saved one. Only arrays
  and JSON are stored: no pickle, so loading a file runs no code from it.

This module writes (its functions take any object with a posterior's attributes, so that
:class:`~torchshm.inference.Posterior` can call them); :mod:`.netcdf_load` reads.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import xarray as xr

from torchshm.inference.priors_json import priors_to_json
from torchshm.inference.summary import as_chains

if TYPE_CHECKING:
    from pyvbmc import VariationalPosterior

ENGINE = "h5netcdf"
FORMAT_VERSION = 1


def _chains(post: Any, values: np.ndarray) -> np.ndarray:
    """Flat step-major values (`S x ...`) as (`chain x draw x ...`)."""
    return as_chains(values, post.n_chains)


def _posterior_group(post: Any) -> xr.Dataset:
    chains = _chains(post, post.samples)
    data = {name: (("chain", "draw"), chains[..., i]) for i, name in enumerate(post.names)}
    attrs = {
        "format": "torchshm-posterior", "format_version": FORMAT_VERSION,
        "method": post.method, "names": json.dumps(post.names),
        "converged": int(post.converged), "n_model_evaluations": int(post.n_model_evaluations),
        "log_evidence": np.nan if post.log_evidence is None else float(post.log_evidence),
        "log_evidence_sd": np.nan if post.log_evidence_sd is None else float(post.log_evidence_sd),
        "priors": json.dumps(priors_to_json(post.priors)),
        "diagnostics": json.dumps(post.diagnostics, default=float),
        "warnings": json.dumps([str(w) for w in post.warnings]),
    }
    return xr.Dataset(data, attrs=attrs)


def _sample_stats_group(post: Any) -> xr.Dataset:
    data = {
        k: (("chain", "draw"), _chains(post, np.asarray(v))) for k, v in post.sample_stats.items()
    }
    scalars = {k: v for k, v in post.diagnostics.items() if isinstance(v, (int, float, str))}
    attrs = {k: (int(v) if isinstance(v, bool) else v) for k, v in scalars.items()}
    return xr.Dataset(data, attrs=attrs)


def _observed_group(post: Any) -> xr.Dataset | None:
    meas = getattr(post.problem, "measurements", None)
    return None if meas is None else observed_dataset(meas)


def observed_dataset(meas: Any) -> xr.Dataset:
    """Measurements as the ``observed_data`` group: ``y(load, x)`` [µε] with a ``line(x)``
    variable for several sensor lines, or ``y(load, point)`` and ``x(point, axis)`` [m] for
    `n x d` coordinates of a field; ``sigma_e`` in the attributes (JSON when per line)."""
    y = np.asarray(meas.y, dtype=np.float64)
    x = np.asarray(meas.x, dtype=np.float64)
    sigma_e = meas.sigma_e  # one level, or one per sensor line (written as JSON)
    attrs = {"units": "microstrain", "sigma_e": float(sigma_e) if not isinstance(sigma_e, dict)
             else json.dumps({str(k): float(v) for k, v in sigma_e.items()})}
    loads = np.asarray(meas.loads, dtype=np.float64)
    line = getattr(meas, "line", None)
    if x.ndim == 2:  # (n, d) coordinates of a field: y on (load, point), x on (point, axis)
        data = {"y": (("load", "point"), y), "x": (("point", "axis"), x)}
        return xr.Dataset(data, coords={"load": loads}, attrs=attrs)
    data = {"y": (("load", "x"), y)}
    if line is not None:  # the sensor line of each reading (positions may repeat across lines)
        data["line"] = (("x",), np.asarray([str(v) for v in line], dtype=object))
    return xr.Dataset(data, coords={"load": loads, "x": x}, attrs=attrs)


def _history_group(post: Any) -> xr.Dataset:
    keys = list(post.history)
    rows = len(next(iter(post.history.values()))) if keys else 0
    value = np.column_stack([post.history[k] for k in keys]) if keys else np.zeros((0, 0))
    return xr.Dataset({"value": (("row", "column"), value.reshape(rows, len(keys)))},
                      coords={"column": np.array(keys, dtype=object)})


def _variational_group(vp: VariationalPosterior) -> xr.Dataset:
    data: dict[str, Any] = {
        "w": (("component",), np.asarray(vp.w, dtype=np.float64).ravel()),
        "mu": (("dim", "component"), np.asarray(vp.mu, dtype=np.float64)),
        "sigma": (("component",), np.asarray(vp.sigma, dtype=np.float64).ravel()),
        "lambd": (("dim",), np.asarray(vp.lambd, dtype=np.float64).ravel()),
    }
    other: dict[str, Any] = {}
    for key, value in vp.parameter_transformer.__getstate__().items():
        if isinstance(value, np.ndarray):
            dims = tuple(f"transformer_{key}_{i}" for i in range(value.ndim))
            data[f"transformer_{key}"] = (dims, np.asarray(value, dtype=np.float64))
        else:
            other[key] = value.tolist() if isinstance(value, np.ndarray) else value
    return xr.Dataset(data, attrs={"transformer_other": json.dumps(other, default=str)})


def save_posterior(post: Any, path: str | Path) -> Path:
    """Write ``post`` to ``path`` (replaced atomically if it exists); returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    groups: list[tuple[str, xr.Dataset | None]] = [
        ("posterior", _posterior_group(post)),
        ("sample_stats", _sample_stats_group(post)),
        ("observed_data", _observed_group(post)),
        ("history", _history_group(post)),
        ("variational_posterior",
         None if post.variational is None else _variational_group(post.variational)),
    ]
    mode = "w"
    for name, ds in groups:
        if ds is not None:
            ds.to_netcdf(tmp, group=name, mode=mode, engine=ENGINE)
            mode = "a"
    os.replace(tmp, path)
    return path


"""A :class:`Posterior` as one netCDF file with InferenceData-style groups (xarray, h5netcdf).

Groups:

- ``posterior``: one variable per parameter, dims ``(chain, draw)``; attributes: method, names,
  convergence, evidence, model evaluations, priors (JSON), diagnostics (JSON) and warnings
  (JSON list of lines; a file written before warnings existed reads as none).
- ``sample_stats``: per-sample statistics, dims ``(chain, draw)`` (emcee: ``lp``).
- ``observed_data``: the measurements of the problem, ``y`` with dims ``(load, x)`` (for `n x d`
  coordinates: ``y(load, point)`` and ``x(point, axis)``).
- ``history``: the per-iteration trace, one variable ``value`` with dims ``(row, column)``.
- ``variational_posterior`` (VBMC): the mixture (``w``, ``mu``, ``sigma``, ``lambd``) and the
  state of PyVBMC's parameter transformer, from which :func:`load_posterior` rebuilds a
  ``VariationalPosterior`` whose ``pdf`` and ``sample`` are those of the saved one. Only arrays
  and JSON are stored: no pickle, so loading a file runs no code from it.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import xarray as xr

from torchshm.inference.posterior import Posterior, as_chains
from torchshm.inference.priors_json import priors_from_json, priors_to_json

if TYPE_CHECKING:
    from pyvbmc import VariationalPosterior

ENGINE = "h5netcdf"
FORMAT_VERSION = 1


def _chains(post: Posterior, values: np.ndarray) -> np.ndarray:
    """Flat step-major values (`S x ...`) as (`chain x draw x ...`)."""
    return as_chains(values, post.n_chains)


def _posterior_group(post: Posterior) -> xr.Dataset:
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


def _sample_stats_group(post: Posterior) -> xr.Dataset:
    data = {
        k: (("chain", "draw"), _chains(post, np.asarray(v))) for k, v in post.sample_stats.items()
    }
    scalars = {k: v for k, v in post.diagnostics.items() if isinstance(v, (int, float, str))}
    attrs = {k: (int(v) if isinstance(v, bool) else v) for k, v in scalars.items()}
    return xr.Dataset(data, attrs=attrs)


def _observed_group(post: Posterior) -> xr.Dataset | None:
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


def _history_group(post: Posterior) -> xr.Dataset:
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


def save_posterior(post: Posterior, path: str | Path) -> Path:
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


def _rebuild_variational(ds: xr.Dataset) -> Any:
    """A PyVBMC ``VariationalPosterior`` from the ``variational_posterior`` group."""
    from pyvbmc import VariationalPosterior
    from pyvbmc.parameter_transformer import ParameterTransformer

    state: dict[str, Any] = json.loads(ds.attrs["transformer_other"])
    for name in ds.data_vars:
        if str(name).startswith("transformer_"):
            state[str(name)[len("transformer_"):]] = ds[name].values.copy()
    transformer = ParameterTransformer.__new__(ParameterTransformer)
    transformer.__setstate__(state)
    mu = ds["mu"].values
    vp = VariationalPosterior(D=mu.shape[0], K=mu.shape[1], parameter_transformer=transformer)
    vp.w = ds["w"].values.reshape(1, -1).copy()
    vp.eta = np.log(vp.w)
    vp.mu = mu.copy()
    vp.sigma = ds["sigma"].values.reshape(1, -1).copy()
    vp.lambd = ds["lambd"].values.reshape(-1, 1).copy()
    return vp


def load_posterior(path: str | Path) -> Posterior:
    """Read a posterior written by :meth:`Posterior.save` (``problem`` is None afterwards).

    Raises:
        FileNotFoundError: when ``path`` does not exist.
        ValueError: when ``path`` is not a torchshm posterior file, or is truncated or
            damaged (one line naming the file).
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no posterior file {path}")
    try:
        with xr.open_dataset(path, group="posterior", engine=ENGINE) as ds:
            ds = ds.load()
    except (OSError, ValueError, KeyError) as exc:  # h5py/h5netcdf: not HDF5, truncated, no group
        first = next((line.strip() for line in str(exc).splitlines() if line.strip()), "")
        raise ValueError(f"{path} is not a readable torchshm posterior file (truncated or "
                         f"damaged?): {first or type(exc).__name__}") from None
    if ds.attrs.get("format") != "torchshm-posterior":
        raise ValueError(f"{path} is not a torchshm posterior file (no 'format' attribute)")
    names = json.loads(ds.attrs["names"])
    samples = np.stack([ds[n].values for n in names], axis=-1)  # chain x draw x D
    n_chain = samples.shape[0]
    groups = _open_groups(path)
    hist = groups.get("history")
    history = {} if hist is None else {
        str(k): hist["value"].values[:, i] for i, k in enumerate(hist["column"].values)
    }
    stats = groups.get("sample_stats")
    sample_stats = {} if stats is None else {
        str(k): _flat(stats[k].values) for k in stats.data_vars
    }
    vp_ds = groups.get("variational_posterior")
    ev, ev_sd = float(ds.attrs["log_evidence"]), float(ds.attrs["log_evidence_sd"])
    return Posterior(
        names=names, method=str(ds.attrs["method"]), samples=_flat(samples),
        log_evidence=None if np.isnan(ev) else ev,
        log_evidence_sd=None if np.isnan(ev_sd) else ev_sd,
        n_model_evaluations=int(ds.attrs["n_model_evaluations"]),
        converged=bool(int(ds.attrs["converged"])), diagnostics=json.loads(ds.attrs["diagnostics"]),
        priors=priors_from_json(json.loads(ds.attrs["priors"])), history=history,
        sample_stats=sample_stats,
        variational=None if vp_ds is None else _rebuild_variational(vp_ds),
        n_chains=n_chain, warnings=[str(w) for w in json.loads(ds.attrs.get("warnings", "[]"))],
        problem=None,
    )


def _flat(values: np.ndarray) -> np.ndarray:
    """(`chain x draw x ...`) values as flat step-major (`S x ...`): inverse of :func:`_chains`."""
    return np.swapaxes(values, 0, 1).reshape(-1, *values.shape[2:])


def _open_groups(path: Path) -> dict[str, xr.Dataset]:
    """The optional groups present in the file, loaded into memory."""
    import h5py

    with h5py.File(path, "r") as fh:
        present = set(fh.keys())
    out = {}
    for name in ("sample_stats", "history", "variational_posterior", "observed_data"):
        if name in present:
            with xr.open_dataset(path, group=name, engine=ENGINE) as ds:
                out[name] = ds.load()
    return out

"""Reading a posterior file written by :func:`torchshm.inference.netcdf.save_posterior`."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from torchshm.inference.netcdf import ENGINE
from torchshm.inference.posterior import Posterior
from torchshm.inference.priors_json import priors_from_json


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
    """(`chain x draw x ...`) values as flat step-major (`S x ...`): inverse of :func:`torchshm.inference.summary.as_chains`."""
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

"""A posterior of measurements on `n x d` coordinates keeps them in its netCDF file."""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import xarray as xr

import torchshm
from torchshm.inference import Posterior, load_posterior


def _saved(tmp_path, x: np.ndarray, rng: np.random.Generator):
    meas = torchshm.Measurements(x, rng.normal(size=(2, len(x))), [0.5, 1.0], sigma_e=3.0)
    post = Posterior(names=["a"], method="emcee", samples=rng.normal(size=(20, 1)), n_chains=2,
                     problem=SimpleNamespace(measurements=meas))  # type: ignore[arg-type]
    path = post.save(tmp_path / "post.nc")
    with xr.open_dataset(path, group="observed_data", engine="h5netcdf") as ds:
        return meas, ds.load(), load_posterior(path)


def test_coordinates_are_written_on_point_and_axis(tmp_path, rng: np.random.Generator) -> None:
    xy = np.array([[0.0, 0.0], [0.5, 0.0], [0.0, 0.25], [0.5, 0.25]])
    meas, ds, back = _saved(tmp_path, xy, rng)
    assert ds["y"].dims == ("load", "point") and ds["x"].dims == ("point", "axis")
    assert np.array_equal(ds["x"].values, xy) and np.array_equal(ds["y"].values, meas.y)
    assert np.array_equal(ds["load"].values, [0.5, 1.0]) and float(ds.attrs["sigma_e"]) == 3.0
    assert back.names == ["a"] and back.samples.shape == (20, 1)


def test_positions_keep_the_load_x_layout(tmp_path, rng: np.random.Generator) -> None:
    meas, ds, _ = _saved(tmp_path, np.array([0.0, 0.1, 0.2]), rng)
    assert ds["y"].dims == ("load", "x") and np.array_equal(ds["x"].values, [0.0, 0.1, 0.2])


def test_sensor_lines_and_their_noise_levels_are_written(tmp_path, rng: np.random.Generator) -> None:
    x = np.array([0.0, 0.1, 0.2, 0.0, 0.1])
    meas = torchshm.Measurements(x, rng.normal(size=(2, 5)), [0.5, 1.0], sigma_e={"a": 0.1, "b": 0.3},
                                 line=["a", "a", "a", "b", "b"])
    post = Posterior(names=["a"], method="emcee", samples=rng.normal(size=(20, 1)), n_chains=2,
                     problem=SimpleNamespace(measurements=meas))  # type: ignore[arg-type]
    path = post.save(tmp_path / "post.nc")
    with xr.open_dataset(path, group="observed_data", engine="h5netcdf") as ds:
        assert list(ds["line"].values) == ["a", "a", "a", "b", "b"]
        assert json.loads(ds.attrs["sigma_e"]) == {"a": 0.1, "b": 0.3}
        assert np.array_equal(ds["y"].values, meas.y)
    assert load_posterior(path).samples.shape == (20, 1)


def test_to_arviz_takes_field_coordinates_and_lines(rng: np.random.Generator) -> None:
    xy = np.array([[0.0, 0.0], [0.5, 0.0], [0.0, 0.25]])
    meas = torchshm.Measurements(xy, rng.normal(size=(2, 3)), [0.5, 1.0], sigma_e=3.0)
    post = Posterior(names=["a"], method="emcee", samples=rng.normal(size=(20, 1)), n_chains=2,
                     problem=SimpleNamespace(measurements=meas))  # type: ignore[arg-type]
    observed = post.to_arviz().observed_data
    assert observed["y"].dims == ("load", "point") and np.array_equal(observed["x"].values, xy)
    lines = torchshm.Measurements([0.0, 0.1, 0.0, 0.1], rng.normal(size=(1, 4)), [0.5], line=["a", "a", "b", "b"])
    post.problem = SimpleNamespace(measurements=lines)  # type: ignore[assignment]
    observed = post.to_arviz().observed_data
    assert list(observed["line"].values) == ["a", "a", "b", "b"] and observed["y"].shape == (1, 4)

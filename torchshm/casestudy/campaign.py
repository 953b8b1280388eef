"""The shipped synthetic measurement campaign of bridge 705.

The paper's fibre data are not public. In their place the library ships the noise-free,
gauge-averaged strains of a *truth* structure that is richer than the model
(:mod:`torchshm.casestudy.truth`), computed once by ``scripts/make_campaign.py``. Loading needs no
finite element solve: :func:`synthetic_campaign` reads those strains and adds, with
``numpy.random.default_rng(seed)``, a random offset per load case (the residual of the
campaign's offset adjustment) and independent measurement noise. The same seed gives the same
measurements in any process.

File layout (``bridge705_campaign.nc``, netCDF-4 through xarray/h5netcdf):

- coordinates ``load`` (`L`, front-axle positions [m]) and ``x`` (`n`, fibre positions [m]);
- variable ``strain_truth`` (``load``, ``x``): noise-free gauge-averaged strains [µε];
- attributes ``truth_E_c`` [GPa], ``truth_log10_K_r``, ``sigma_e`` [µε], ``offset_sd`` [µε],
  ``model_identity`` (the model it was made for), ``truth_config`` (JSON) and ``description``.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from torchshm.casestudy.truth import TruthConfig, gauge_average, solve, spread_loads, truth_mesh, truth_strains
from torchshm.data.measurements import Measurements

#: the shipped campaign file
CAMPAIGN_PATH = Path(__file__).with_name("bridge705_campaign.nc")


@dataclass(frozen=True)
class CampaignTruth:
    """Contents of a campaign file.

    Attributes:
        x: `n` fibre positions [m].
        loads: `L` front-axle positions [m].
        strain: `L x n` noise-free, gauge-averaged truth strains [µε].
        attrs: file metadata (truth parameters, noise levels, provenance).
    """

    x: np.ndarray
    loads: np.ndarray
    strain: np.ndarray
    attrs: dict[str, float | str]

    @property
    def sigma_e(self) -> float:
        """Standard deviation of the measurement noise [µε]."""
        return float(self.attrs["sigma_e"])

    @property
    def offset_sd(self) -> float:
        """Standard deviation of the per-load-case offset residual [µε]."""
        return float(self.attrs["offset_sd"])


def write_campaign(truth: CampaignTruth, path: str | Path) -> Path:
    """Write a campaign file (layout in the module docstring); returns the path."""
    import xarray as xr

    dataset = xr.Dataset(
        {"strain_truth": (("load", "x"), np.asarray(truth.strain, dtype=np.float64))},
        coords={
            "load": np.asarray(truth.loads, dtype=np.float64),
            "x": np.asarray(truth.x, dtype=np.float64),
        },
        attrs=dict(truth.attrs),
    )
    dataset["strain_truth"].attrs["units"] = "microstrain"
    dataset["x"].attrs["units"] = "m"
    dataset["load"].attrs["units"] = "m"
    path = Path(path)
    dataset.to_netcdf(path, engine="h5netcdf")
    _read.cache_clear()  # a rewritten file must not be served from the cache
    return path


@lru_cache(maxsize=4)
def _read(path: Path) -> CampaignTruth:
    import xarray as xr

    if not path.exists():
        raise FileNotFoundError(f"campaign file not found: {path} (run scripts/make_campaign.py)")
    with xr.open_dataset(path, engine="h5netcdf") as dataset:
        dataset = dataset.load()
        attrs = {k: (v.item() if isinstance(v, np.generic) else v) for k, v in dataset.attrs.items()}
        return CampaignTruth(
            x=dataset["x"].values.astype(np.float64),
            loads=dataset["load"].values.astype(np.float64),
            strain=dataset["strain_truth"].values.astype(np.float64),
            attrs=attrs,
        )


def campaign_truth(path: str | Path | None = None) -> CampaignTruth:
    """The noise-free contents of a campaign file (the shipped one by default); arrays are copies."""
    truth = _read(Path(path) if path is not None else CAMPAIGN_PATH)
    return CampaignTruth(truth.x.copy(), truth.loads.copy(), truth.strain.copy(), dict(truth.attrs))


def synthetic_campaign(
    seed: int = 0, path: str | Path | None = None, pitch: float | None = None, lines: int = 1
) -> Measurements:
    """Synthetic fibre measurements of bridge 705: 12 load cases at 0.1 m pitch (35–70 m).

    ``y = strain_truth + offset_l + e``, with one offset ``offset_l ~ N(0, offset_sd²)`` per
    load case and independent ``e ~ N(0, sigma_e²)``, drawn in that order from
    ``numpy.random.default_rng(seed)``. With ``lines=2`` a second fibre runs along the top face
    of the deck at the same positions (line labels ``"bottom"``, ``"top"``): its truth strains
    are computed from the same truth structure (:func:`top_face_truth`) and its own offsets and
    noise are drawn after the bottom fibre's, so the bottom line equals the one-fibre campaign.

    Args:
        seed: seed of the noise; the same seed gives identical measurements in every process.
        path: a campaign file; defaults to the shipped ``bridge705_campaign.nc``.
        pitch: spacing of the readings [m]. ``None`` (or the file's own pitch) reads the file;
            another pitch (e.g. 0.005) computes the same truth structure's gauge-averaged
            strains at every ``pitch`` from 35 to 70 m (:func:`dense_truth`, cached per
            pitch in this process), with the file's noise levels and truth parameters.
        lines: 1 (bottom fibre) or 2 (bottom and top face; the model is
            ``torchshm.bridge705(lines=2)``).

    Returns:
        Measurements `L x n` [µε] with ``sigma_e`` from the file and the truth parameters in
        ``attrs`` (``truth_E_c`` [GPa], ``truth_log10_K_r``).
    """
    if lines not in (1, 2):
        raise ValueError(f"synthetic_campaign: lines must be 1 or 2, got {lines!r}")
    truth = campaign_truth(path)
    if pitch is not None and not np.isclose(pitch, np.median(np.diff(truth.x)), rtol=1e-9, atol=0.0):
        truth = dense_truth(float(pitch), truth)
    rng = np.random.default_rng(seed)
    offsets = rng.normal(0.0, truth.offset_sd, size=(truth.loads.size, 1))
    noise = rng.normal(0.0, truth.sigma_e, size=truth.strain.shape)
    attrs: dict[str, float | int | str] = {
        "source": "torchshm synthetic campaign of bridge 705",
        "seed": int(seed),
        "truth_E_c": float(truth.attrs["truth_E_c"]),
        "truth_log10_K_r": float(truth.attrs["truth_log10_K_r"]),
        "offset_sd": truth.offset_sd,
    }
    y = truth.strain + offsets + noise
    if lines == 1:
        return Measurements(truth.x, y, truth.loads, sigma_e=truth.sigma_e, attrs=attrs)
    top = top_face_truth(truth)
    top = top + rng.normal(0.0, truth.offset_sd, size=(truth.loads.size, 1))
    top = top + rng.normal(0.0, truth.sigma_e, size=top.shape)
    line = np.repeat(np.array(["bottom", "top"]), truth.x.size)
    return Measurements(
        np.tile(truth.x, 2), np.hstack([y, top]), truth.loads, sigma_e=truth.sigma_e, attrs=attrs, line=line
    )


def top_face_truth(truth: CampaignTruth) -> np.ndarray:
    """Noise-free, gauge-averaged top-face strains `L x n` [µε] of the truth structure at the
    positions of ``truth`` (same mesh, loads and gauge as the bottom fibre; the top face lies
    ``depth - c_b`` above the deck axis, with the haunches and the neutral-axis shifts of
    :func:`~torchshm.casestudy.truth.deck_sections`).

    Raises:
        ValueError: for a campaign made for other truth parameters.
    """

    default = TruthConfig()
    made_for = (float(truth.attrs["truth_E_c"]), float(truth.attrs["truth_log10_K_r"]))
    if made_for != (default.E_c, default.log10_K_r):
        raise ValueError("synthetic_campaign: lines=2 needs the shipped truth parameters")
    pitch = float(np.round(np.median(np.diff(truth.x)), 9))
    x, strain = _top_strain(pitch, float(truth.x[0]), float(truth.x[-1]))
    if x.shape != truth.x.shape or not np.allclose(x, truth.x, atol=1e-9, rtol=0.0):
        raise ValueError("synthetic_campaign: lines=2 needs the truth's equally spaced sensor positions")
    return strain.copy()


@lru_cache(maxsize=4)
def _top_strain(pitch: float, start: float, end: float) -> tuple[np.ndarray, np.ndarray]:
    import dataclasses

    import torch


    default = TruthConfig()
    model = dataclasses.replace(default.model, sensor_pitch=pitch, sensor_start=start, sensor_end=end)
    config = dataclasses.replace(default, model=model)
    mesh, c_b = truth_mesh(config)
    forces = [spread_loads(mesh, model.truck, f, model.length, config.load_spread) for f in model.loads]
    U = solve(mesh.frame, torch.stack(forces, dim=1))
    mid = 0.5 * (mesh.deck_x[1:] + mesh.deck_x[:-1])
    to_pier = np.min(np.abs(mid[:, None] - model.pier_x()[None, :]), axis=1)
    depth = model.deck.depth + config.haunch_depth * np.clip(1.0 - to_pier / config.haunch_length, 0.0, None)
    c_top = -(1000.0 * depth - c_b)  # [mm], negative: above the axis
    strain = (1e6 * gauge_average(mesh, U, c_top, model.sensor_x(), config.gauge_length).T).numpy()
    strain.setflags(write=False)
    return model.sensor_x(), strain


def dense_truth(pitch: float, shipped: CampaignTruth) -> CampaignTruth:
    """The shipped campaign's truth at another reading pitch [m] (computed, not resampled).

    The truth structure is :class:`~torchshm.casestudy.truth.TruthConfig` with the fibre
    positions at ``pitch``; its parameters must be those the file was made with (checked).

    Raises:
        ValueError: for a pitch that is not a positive number, or a file made for other
            truth parameters.
    """
    if not isinstance(pitch, float) or not np.isfinite(pitch) or pitch <= 0:
        raise ValueError(f"synthetic_campaign: pitch must be a positive number of metres, got {pitch!r}")

    default = TruthConfig()
    made_for = (float(shipped.attrs["truth_E_c"]), float(shipped.attrs["truth_log10_K_r"]))
    if made_for != (default.E_c, default.log10_K_r):
        raise ValueError(f"synthetic_campaign: pitch= needs the shipped truth, this file has {made_for}")
    x, strain = _dense_strain(pitch)
    return CampaignTruth(x.copy(), shipped.loads.copy(), strain.copy(), dict(shipped.attrs))


@lru_cache(maxsize=4)
def _dense_strain(pitch: float) -> tuple[np.ndarray, np.ndarray]:
    import dataclasses


    default = TruthConfig()
    config = dataclasses.replace(default, model=dataclasses.replace(default.model, sensor_pitch=pitch))
    strain = truth_strains(config).numpy()
    strain.setflags(write=False)
    x = config.model.sensor_x()
    x.setflags(write=False)
    return x, strain


def discrepancy_summary(discrepancy: np.ndarray, pitch: float) -> tuple[float, float]:
    """Root mean square [µε] and correlation length [m] of a discrepancy along the fibre.

    The correlation length is the lag at which the empirical autocorrelation, pooled over load
    cases, ``ρ(k) = mean_{l,i}(d[l, i] d[l, i + k]) / mean_{l,i}(d[l, i]²)``, first drops below
    1/e, interpolated linearly between lags.

    Args:
        discrepancy: `L x n` discrepancy [µε] at equally spaced positions.
        pitch: spacing of the positions [m].
    """
    d = np.atleast_2d(np.asarray(discrepancy, dtype=np.float64))
    power = float(np.mean(d**2))
    previous = 1.0
    for k in range(1, d.shape[1]):
        rho = float(np.mean(d[:, :-k] * d[:, k:])) / power
        if rho < np.exp(-1.0):
            return float(np.sqrt(power)), pitch * (k - 1 + (previous - np.exp(-1.0)) / (previous - rho))
        previous = rho
    return float(np.sqrt(power)), float("inf")

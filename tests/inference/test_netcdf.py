"""Saving and loading a posterior: one netCDF file with InferenceData-style groups."""

from __future__ import annotations

import h5py
import numpy as np
import pytest
from pyvbmc import VariationalPosterior
from pyvbmc.parameter_transformer import ParameterTransformer
from scipy.stats import ortho_group

from torchshm import Gamma, Normal, Uniform
from torchshm.inference import Posterior, load_posterior


def _mixture(rng: np.random.Generator, rotated: bool) -> VariationalPosterior:
    """A 3-D, 4-component variational posterior on a box bounded in two coordinates."""
    lb, ub = np.array([[0.0, 10.0, -np.inf]]), np.array([[5.0, 100.0, np.inf]])
    plb, pub = np.array([[0.2, 20.0, -1.0]]), np.array([[2.0, 60.0, 1.0]])
    kwargs = {"scale": np.array([1.5, 0.7, 2.0]), "rotation_matrix": ortho_group.rvs(3, random_state=1)} if rotated else {}
    pt = ParameterTransformer(3, lb, ub, plb, pub, transform_type="probit", **kwargs)
    vp = VariationalPosterior(D=3, K=4, parameter_transformer=pt, rng=rng)
    vp.mu = rng.normal(size=(3, 4))
    vp.sigma = rng.uniform(0.2, 1.0, size=(1, 4))
    vp.lambd = rng.uniform(0.5, 2.0, size=(3, 1))
    vp.w = rng.dirichlet(np.ones(4)).reshape(1, 4)
    return vp


@pytest.mark.parametrize("rotated", [False, True])
def test_variational_posterior_survives_save_and_load(tmp_path, rng: np.random.Generator, rotated: bool) -> None:
    vp = _mixture(rng, rotated)
    priors = {"s": Gamma(2.0, 2.0, bounds=(0.0, 5.0), plausible=(0.2, 2.0)), "E": Uniform(10.0, 100.0),
              "c": Normal(0.0, 1.0), "fixed": 0.25}
    post = Posterior(
        names=["s", "E", "c"], method="vbmc", samples=vp.sample(1000)[0], log_evidence=-12.5,
        log_evidence_sd=0.02, n_model_evaluations=77, converged=True,
        diagnostics={"iterations": 9, "message": "stable", "r_index": 0.1},
        priors=priors, history={"iteration": np.arange(3.0), "s/mean": np.array([1.0, 1.1, 1.2])},
        variational=vp,
    )
    back = load_posterior(post.save(tmp_path / "post.nc"))
    theta = vp.sample(50)[0]
    assert np.allclose(back.log_pdf(theta), post.log_pdf(theta), rtol=1e-12, atol=1e-12)
    assert np.array_equal(back.sample(20, rng=3), post.sample(20, rng=3))
    assert back.log_pdf(np.array([6.0, 50.0, 0.0])) == -np.inf  # outside the hard bounds
    assert np.array_equal(back.samples, post.samples)
    assert (back.names, back.method, back.converged, back.n_model_evaluations) == (["s", "E", "c"], "vbmc", True, 77)
    assert (back.log_evidence, back.log_evidence_sd) == (-12.5, 0.02)
    assert back.diagnostics == post.diagnostics
    assert np.array_equal(back.history["s/mean"], [1.0, 1.1, 1.2])
    assert back.problem is None
    assert back.priors["fixed"] == 0.25 and repr(back.priors["s"]) == "Gamma(2, 2)"
    assert back.priors["s"].hard_bounds == (0.0, 5.0) and back.priors["s"].plausible_bounds == (0.2, 2.0)
    assert back.priors["E"].plausible_bounds == pytest.approx(priors["E"].plausible_bounds)
    assert back.priors["c"].hard_bounds == (-np.inf, np.inf)


def test_mcmc_chains_keep_their_layout(tmp_path, rng: np.random.Generator) -> None:
    steps, walkers = 30, 4
    chain = rng.normal(size=(steps, walkers, 2))
    lp = rng.normal(size=(steps, walkers))
    post = Posterior(names=["a", "b"], method="emcee", samples=chain.reshape(-1, 2), n_chains=walkers,
                     sample_stats={"lp": lp.reshape(-1)}, diagnostics={"tau_max": float("nan")})
    path = post.save(tmp_path / "chain.nc")
    back = load_posterior(path)
    assert np.array_equal(back.samples, post.samples) and back.n_chains == walkers
    assert np.array_equal(back.sample_stats["lp"], lp.reshape(-1))
    assert back.log_evidence is None and back.variational is None and np.isnan(back.diagnostics["tau_max"])
    with h5py.File(path) as fh:
        assert {"posterior", "sample_stats", "history"} <= set(fh)
        assert fh["posterior/a"].shape == (walkers, steps)  # (chain, draw)
        assert np.array_equal(fh["posterior/a"][1], chain[:, 1, 0])  # walker 1 is chain 1


def test_loading_another_netcdf_file_names_the_problem(tmp_path) -> None:
    import xarray as xr

    xr.Dataset({"v": ("i", np.arange(3.0))}).to_netcdf(tmp_path / "x.nc", group="posterior", engine="h5netcdf")
    with pytest.raises(ValueError, match="not a torchshm posterior"):
        load_posterior(tmp_path / "x.nc")

"""Every option of every config group composes, and lands in the typed settings."""

from __future__ import annotations

from pathlib import Path

import pytest

import torchshm
from torchshm.config.schema import EmulatorConfig
from torchshm.config import (
    CONF_DIR,
    EmceeConfig,
    KernelName,
    ModelName,
    VBMCConfig,
    method_options,
    normalize_overrides,
    register_configs,
    to_settings,
)


def options(group: str) -> list[str]:
    return sorted(p.stem for p in (CONF_DIR / group).glob("*.yaml"))


def test_defaults_are_the_emulator_on_the_paper_sub_case_a2(compose_cfg) -> None:
    s = to_settings(compose_cfg())
    assert s.method.name == "emulator" and isinstance(s.method, EmulatorConfig)
    assert s.kernel.name is KernelName.matern32
    assert s.model == {"_target_": "torchshm.bridge705_surrogate"}
    assert s.executor.kind == "serial" and s.executor.n_jobs == 1
    assert s.data.path is None and s.data.loads == [39.8] and s.data.resolution == 0.1
    assert s.predict.loads == [47.5, 55.1, 62.8, 70.4]
    assert s.likelihood.sigma_m == 0.05 and s.likelihood.sigma_e is None
    assert s.seed == 0 and s.store is None
    assert list(s.priors) == ["E_c", "log10_K_r", "sigma_a", "length"]


def test_kernel_group_has_every_kernel_of_table_6() -> None:
    from hydra.core.config_store import ConfigStore

    register_configs()
    stored = ConfigStore.instance().list("kernel")
    from torchshm.kernels import kernel_names

    groups = sorted(n.removesuffix(".yaml") for n in stored)
    assert set(torchshm.KERNELS) <= set(groups)  # Table 6, and kernels of their own form
    assert groups == sorted(kernel_names()) == sorted(k.value for k in KernelName)


@pytest.mark.parametrize("kernel", sorted(k.value for k in KernelName))
def test_each_kernel_option(compose_cfg, kernel: str) -> None:
    assert to_settings(compose_cfg(f"kernel={kernel}")).kernel.name.value == kernel


@pytest.mark.parametrize("model, target", [("fe", "torchshm.bridge705"),
                                           ("surrogate", "torchshm.bridge705_surrogate")])
def test_each_model_option(compose_cfg, model: str, target: str) -> None:
    assert options("model") == sorted(m.value for m in ModelName)
    assert to_settings(compose_cfg(f"model={model}")).model == {"_target_": target}


def test_method_vbmc_options(compose_cfg) -> None:
    s = to_settings(compose_cfg("method=vbmc", "method.max_fun_evals=60"))
    assert isinstance(s.method, VBMCConfig)
    assert method_options(s.method) == {"max_fun_evals": 60, "n_samples": 100_000}


def test_method_vbmc_takes_its_budget_under_the_emulators_name(compose_cfg) -> None:
    from torchshm.inference.registry import resolve_aliases  # as the command line's job does

    def options(*overrides: str) -> dict:
        s = to_settings(compose_cfg("method=vbmc", *overrides))
        return resolve_aliases(s.method.name, method_options(s.method))

    assert options("method.max_model_evaluations=70") == {"max_fun_evals": 70, "n_samples": 100_000}
    assert options("method.max_model_evaluations=70", "method.max_fun_evals=70")["max_fun_evals"] == 70
    with pytest.raises(ValueError, match=r"max_model_evaluations .* = 70 and max_fun_evals .* = 80 name the same setting"):
        options("method.max_model_evaluations=70", "method.max_fun_evals=80")


def test_method_emcee_has_the_paper_settings(compose_cfg) -> None:
    s = to_settings(compose_cfg("method=emcee"))
    assert isinstance(s.method, EmceeConfig)
    assert (s.method.n_walkers, s.method.n_steps) == (40, 2000)
    assert method_options(s.method) == {"n_walkers": 40, "n_steps": 2000, "thin": 1,
                                        "log_every": 100, "window": 1000}
    s = to_settings(compose_cfg("method=emcee", "method.n_walkers=8", "method.burn=10"))
    assert method_options(s.method)["n_walkers"] == 8 and method_options(s.method)["burn"] == 10


def test_method_yaml_matches_schema_defaults(compose_cfg) -> None:
    assert to_settings(compose_cfg("method=vbmc")).method == VBMCConfig()
    assert to_settings(compose_cfg("method=emcee")).method == EmceeConfig()
    assert to_settings(compose_cfg("method=emulator")).method == EmulatorConfig()


def test_every_emulator_option_is_a_key_with_the_runners_default(compose_cfg) -> None:
    """Each keyword of :func:`run_emulator` but where runs go (``n_jobs``, ``executor``: the
    ``executor`` group) can be set from the command line, and its default there is the API's."""
    import dataclasses
    import inspect

    from torchshm.inference.adaptive.method import run_emulator

    api = {p.name: p.default for p in inspect.signature(run_emulator).parameters.values()
           if p.default is not inspect.Parameter.empty}
    keys = {f.name: getattr(EmulatorConfig(), f.name) for f in dataclasses.fields(EmulatorConfig)}
    for name in set(api) - {"seed", "log_dir", "n_jobs", "executor"}:
        assert name in keys and keys[name] == api[name], name
    s = to_settings(compose_cfg("method.n_walkers=48", "method.error_draws=2"))
    assert (method_options(s.method)["n_walkers"], method_options(s.method)["error_draws"]) == (48, 2)


@pytest.mark.parametrize("option", ["0.1", "0.2", "0.5", "1", "2", "4"])
def test_each_resolution_option(compose_cfg, option: str) -> None:
    assert options("resolution") == sorted(["0.1", "0.2", "0.5", "1", "2", "4"])
    s = to_settings(compose_cfg(*normalize_overrides([f"resolution={option}"])))
    assert s.data.resolution == pytest.approx(float(option))


def test_resolution_written_as_float_selects_the_file(compose_cfg) -> None:
    s = to_settings(compose_cfg(*normalize_overrides(["resolution=1.0"])))
    assert s.data.resolution == 1.0


def test_data_and_predict_values(compose_cfg, tmp_path: Path) -> None:
    s = to_settings(compose_cfg(
        f"data.path={tmp_path / 'm.csv'}", "data.loads=[39.8,47.5]", "predict.loads=[]",
        "seed=7", "store=runs/evals.sqlite", "likelihood.sigma_e=0.2", "data.resolution=null",
    ))
    assert s.data.path == str(tmp_path / "m.csv")
    assert s.data.loads == [39.8, 47.5] and s.predict.loads == []
    assert s.seed == 7 and s.store == "runs/evals.sqlite" and s.likelihood.sigma_e == 0.2
    assert s.data.resolution is None


def test_hydra_run_and_sweep_dirs_are_relative_and_named_by_overrides(compose_cfg) -> None:
    cfg = compose_cfg("kernel=matern52", return_hydra_config=True)
    assert cfg.hydra.job.chdir is False
    assert cfg.hydra.run.dir.startswith("runs/")
    assert cfg.hydra.sweep.dir.startswith("runs/multirun/")
    assert cfg.hydra.run.dir.endswith("_kernel=matern52")
    assert cfg.hydra.sweep.subdir == "kernel=matern52"
    assert compose_cfg(return_hydra_config=True).hydra.sweep.subdir == "default"

"""One identification run from typed settings: the steps of ``torchshm-identify``.

:func:`run_job` reads as the paper's workflow: load the measurements, build the forward model
and the :class:`~torchshm.Problem`, identify the posterior, predict the held-out load cases, and
write every output into the run folder. It receives a :class:`~torchshm.config.Config`
dataclass, never a ``DictConfig``.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from torchshm.config import Config, DataConfig, build_priors, method_options, parameter_labels
from torchshm.cli import outputs
from torchshm.cli.models import instantiate_model, runs_report, with_executor
from torchshm.storage.parallel import ParallelModel
from torchshm.inference.method_checks import charge_check
from torchshm.inference.validate import check_model_output, validate

if TYPE_CHECKING:
    from torchshm.data.measurements import Measurements
    from torchshm.forward.protocol import ForwardModel
    from torchshm.inference.posterior import Posterior
    from torchshm.problem import Problem

log = logging.getLogger(__name__)


@dataclass
class JobResult:
    """What a run produced.

    Attributes:
        posterior: the identified posterior.
        out_dir: the run folder.
        wall_time_s: seconds from loading the data to the last file written.
        files: output name -> path (``posterior``, ``summary``, ``corner``, ...).
        predictive: held-out scores per load case (empty without held-out load cases).
    """

    posterior: Posterior
    out_dir: Path
    wall_time_s: float
    files: dict[str, Path] = field(default_factory=dict)
    predictive: list[dict[str, float]] = field(default_factory=list)


def resolve_path(path: str, base: Path) -> Path:
    """``path`` (``~`` expanded) relative to ``base`` unless absolute."""
    p = Path(path).expanduser()
    return p if p.is_absolute() else base / p


def load_data(data: DataConfig, base: Path) -> Measurements:
    """All load cases of the campaign or file, downsampled to ``data.resolution`` (if set).

    Raises:
        FileNotFoundError: for a missing file; ValueError for a malformed one or a resolution
            that is not a multiple of the pitch.
    """
    import torchshm

    if data.path is None:
        if data.format is not None or data.odisi or data.dic or data.missing is not None:
            raise ValueError("data.format, data.missing, data.odisi and data.dic apply to a file (data.path)")
        lines = 1 if data.lines is None else data.lines
        measurements = torchshm.synthetic_campaign(seed=data.campaign_seed, pitch=data.pitch, lines=lines)
    else:
        measurements = _load_file(data, resolve_path(data.path, base))
    if data.resolution is None:
        return measurements
    return measurements.downsample(data.resolution)


def _load_file(data: DataConfig, path: Path) -> Measurements:
    """The measurements of ``data.path`` in ``data.format`` (ODiSI options from ``data.lines``
    and ``data.odisi``; DIC options from ``data.dic``, ``data.path`` a glob of exports)."""
    import torchshm

    fmt = None if data.format is None else str(data.format).lower()
    if fmt is None and path.suffix.lower() == ".tsv":
        fmt = "odisi"
    if fmt == "dic":
        if data.lines is not None or data.odisi:
            raise ValueError("data.lines and data.odisi do not apply to format=dic (its options go in data.dic)")
        return torchshm.load_measurements(str(path), "dic", missing=data.missing, **dict(data.dic or {}))
    if data.dic:
        raise ValueError("data.dic applies to format=dic")
    options = dict(data.odisi or {})
    if fmt == "odisi":
        if data.lines is not None:
            options["lines"] = {k: tuple(v) if isinstance(v, list) and len(v) == 2 and all(
                isinstance(e, (int, float)) for e in v) else v for k, v in dict(data.lines).items()}
        return torchshm.load_measurements(path, "odisi", missing=data.missing, **options)
    if data.lines is not None or options:
        raise ValueError("data.lines and data.odisi apply to format=odisi and the synthetic campaign; "
                         f"{path.name} names its own lines")
    return torchshm.load_measurements(path, fmt, missing=data.missing)


def build_model(settings: Config, base: Path) -> ForwardModel:
    """The forward model of ``settings.model`` (``_target_`` and keyword arguments), wrapped
    for parallel runs when ``settings.executor`` is not serial.

    Raises:
        ValueError: in one line, for a ``_target_`` that does not import or build a model.
    """
    model = instantiate_model(settings.model, base)
    return with_executor(model, settings.executor)


def build_problem(settings: Config, model: ForwardModel, measurements: Measurements, base: Path,
                  priors: dict[str, Any] | None = None) -> Problem:
    """The :class:`~torchshm.Problem` of the inference load cases ``settings.data.loads``.

    Args:
        settings: the run's settings.
        model: the forward model.
        measurements: every load case of the campaign (the inference ones are selected here).
        base: directory a relative ``settings.store`` is resolved against.
        priors: the built priors; default built from ``settings.priors``.
    """
    import torchshm

    store = None if settings.store is None else resolve_path(settings.store, base)
    if store is not None:
        try:
            store.parent.mkdir(parents=True, exist_ok=True)
        except OSError as err:
            raise ValueError(f"store {store}: cannot create its folder ({err.strerror}: {err.filename})") from None
    return torchshm.Problem(
        model,
        measurements.select(settings.data.loads),
        kernel=settings.kernel.name.value,
        priors=build_priors(settings.priors) if priors is None else priors,
        sigma_m=_noise_level(settings.likelihood, "sigma_m"),
        sigma_e=_noise_level(settings.likelihood, "sigma_e"),
        store=store,
        match=settings.likelihood.match,
        discrepancy=settings.likelihood.discrepancy,
    )


def _noise_level(likelihood: Any, name: str) -> object:
    """``likelihood.<name>``: a number (or None), or the prior its mapping describes (a priors
    entry: ``{dist: uniform, a: 0, b: 0.2}``), which makes the level inferred.

    Raises:
        ValueError: ``likelihood.<name>: ...`` for anything else, or a bad prior entry.
    """
    from omegaconf import OmegaConf

    from torchshm.config.priors import build_prior
    from torchshm.config.schema import PriorConfig

    value = getattr(likelihood, name)
    if value is None or (isinstance(value, (int, float)) and not isinstance(value, bool)):
        return value
    if isinstance(value, Mapping) or OmegaConf.is_dict(value):
        try:
            entry = OmegaConf.to_object(OmegaConf.merge(OmegaConf.structured(PriorConfig), value))
        except Exception as err:  # an unknown field or a wrong type in the entry
            raise ValueError(f"likelihood.{name}: not a prior entry ({str(err).splitlines()[0]})") from None
        return build_prior(f"likelihood.{name}", entry)
    raise ValueError(f"likelihood.{name} must be a number or a prior such as "
                     f"{{dist:uniform,a:0,b:0.2}}, got {value!r}")


@dataclass
class PreparedJob:
    """A run whose inputs have all been read and checked; nothing has been evaluated yet."""

    settings: Config
    problem: Problem
    measurements: Measurements
    held_out: Measurements | None
    t0: float
    labels: dict[str, str] = field(default_factory=dict)
    model: Any = None  # the forward model as built (a ParallelModel's Dask client is closed after the run)
    n_checked: int = 0  # model runs of the output check (0 or 1)


def prepare_job(settings: Config, base: Path) -> PreparedJob:
    """Read and check every input of a run (priors, data, load cases, model, options).

    Args:
        settings: the run's typed configuration.
        base: directory that relative ``data.path`` and ``store`` are resolved against.

    Raises:
        ValueError, OSError: for bad input (missing or malformed file, unknown load case, bad
            priors or method options, see :mod:`torchshm.inference.validate`; a held-out
            predictive of ``predict.n`` draws that would not fit in memory), after at most one
            model run (the check of the output's shape and dtype).
    """
    t0 = time.perf_counter()
    if settings.predict.n < 1:
        raise ValueError(f"predict.n must be >= 1, got {settings.predict.n}")
    priors = build_priors(settings.priors)  # cheap checks first
    measurements = load_data(settings.data, base)
    held_out = measurements.select(settings.predict.loads) if settings.predict.loads else None
    model = build_model(settings, base)
    problem = build_problem(settings, model, measurements, base, priors)
    if held_out is not None:  # the held-out predictive comes after inference: refused now, not then
        check_predictive_memory(problem, len(held_out.loads), settings.predict.n)
    method, options = settings.method.name, _options(settings)
    validate(problem, method, settings.seed, None, options)  # one line naming the input, the fix
    check_model_output(problem, method, settings.seed, options)  # at most one model run
    n_checked = int(problem.n_model_evaluations)  # counted with the run's (run_job)
    labels = parameter_labels(settings.priors, model.model if isinstance(model, ParallelModel) else model)
    return PreparedJob(settings, problem, measurements, held_out, t0, labels, model, n_checked)


def _options(settings: Config) -> dict[str, object]:
    """The method's options of ``settings`` for :func:`torchshm.identify`, aliases renamed
    (e.g. VBMC's ``method.max_model_evaluations``: :func:`~torchshm.inference.registry.resolve_aliases`)."""
    from torchshm.inference.registry import resolve_aliases

    return resolve_aliases(settings.method.name, method_options(settings.method))


def check_predictive_memory(problem: Problem, n_loads: int, n: int) -> None:
    """Refuse ``predict.n`` draws of ``n_loads`` held-out load cases that would not fit in
    memory (:func:`~torchshm.predictive.memory.check_memory`, the command line keeps float32
    draws: ``keep="summary"``), in one line naming the need and the fix."""
    from torchshm.predictive.memory import check_memory
    from torchshm.predictive.view import prediction_view

    check_memory(prediction_view(problem), n_loads, n, "summary", problem.kernel,
                 what=("predict.n", "predict.loads"))


def run_job(job: PreparedJob, out_dir: Path) -> JobResult:
    """Identify, predict and write every output of one prepared run into ``out_dir``.

    Errors raised here are failures of the run, not bad input: in a sweep, Hydra records the
    failed job and goes on with the others.
    """
    try:
        return _run(job, out_dir)
    finally:
        if isinstance(job.model, ParallelModel):
            job.model.close()


def _run(job: PreparedJob, out_dir: Path) -> JobResult:
    import torchshm

    settings, problem = job.settings, job.problem
    out_dir.mkdir(parents=True, exist_ok=True)
    log.info("identifying %s with %s (%s kernel, %d load case(s), %d positions)",
             problem.names, settings.method.name, settings.kernel.name.value,
             len(settings.data.loads), job.measurements.n)
    method = settings.method.name
    options = charge_check(method, _options(settings), len(problem.names),
                           len(problem.physical_names), job.n_checked)  # within the budget
    post = torchshm.identify(problem, method=method, seed=settings.seed, log_dir=out_dir / "tb",
                             **options)
    post.n_model_evaluations += job.n_checked
    post.diagnostics["n_check_evaluations"] = job.n_checked
    report = runs_report(problem.model)
    if report is not None:
        log.info("run folders: %s", report)
    result = JobResult(post, out_dir, 0.0)
    result.files.update(outputs.write_posterior(post, out_dir, job.measurements.attrs, job.labels))
    if job.held_out is not None:
        result.predictive, files = outputs.write_predictive(post, job.held_out, settings.predict.n,
                                                            settings.seed, out_dir)
        result.files.update(files)
    result.wall_time_s = time.perf_counter() - job.t0
    result.files["run"] = outputs.write_run_record(result, settings)
    for line in post.warnings:  # printed first with the summary; repeated as the last lines
        log.warning(line)
    return result


__all__ = [
    "JobResult", "PreparedJob", "build_model", "build_problem", "load_data", "prepare_job",
    "resolve_path", "run_job",
]

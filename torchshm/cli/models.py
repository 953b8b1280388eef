"""The forward model of a run, built from its config node with Hydra's ``instantiate``.

A model config (``conf/model/<name>.yaml``, or ``model/<name>.yaml`` in a user's
``--config-dir``) names a class or factory by ``_target_`` and gives its keyword arguments::

    _target_: my_package.my_bridge.MyBridge     # or torchshm.ExternalModel, torchshm.bridge705
    span: 30.0

The module is imported from the directory the command runs from (put first on ``sys.path``,
as ``python -m`` does) or from the installed packages. Only this module instantiates: the
library receives the built model, never a config node.
"""

from __future__ import annotations

import sys
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from torchshm.config import ExecutorConfig

if TYPE_CHECKING:
    from torchshm.forward.protocol import ForwardModel


def instantiate_model(spec: Mapping[str, Any], base: Path) -> ForwardModel:
    """The forward model described by ``spec`` (``_target_`` and keyword arguments).

    Args:
        spec: the ``model`` node as a plain mapping.
        base: the directory the command runs from; put on ``sys.path`` for ``_target_``.

    Raises:
        ValueError: ``model: ...`` in one line when ``_target_`` is missing, does not import,
            or its call fails, or when the result has no ``x`` and ``loads``.
    """
    import hydra.utils
    from hydra.errors import InstantiationException

    target = spec.get("_target_") if isinstance(spec, Mapping) else None
    if not isinstance(target, str) or not target:
        raise ValueError(f"model: the model config needs a _target_ (a class or factory), got {dict(spec)}")
    if str(base) not in sys.path:
        sys.path.insert(0, str(base))
    try:
        model = hydra.utils.instantiate(dict(spec), _convert_="all")
    except InstantiationException as err:
        raise ValueError(f"model: _target_ {target!r}: {_cause(err)}") from None
    except (TypeError, ValueError, OSError) as err:
        raise ValueError(f"model: _target_ {target!r}: {_first_line(err)}") from None
    missing = [a for a in ("x", "loads") if getattr(model, a, None) is None]
    if missing or not callable(model):
        what = f"has no {' or '.join(missing)}" if missing else "is not callable"
        raise ValueError(f"model: {target} built a {type(model).__name__} that {what} "
                         "(a forward model is model(theta_p) with attributes x and loads)")
    return model


def with_executor(model: ForwardModel, executor: ExecutorConfig) -> ForwardModel:
    """``model`` itself for the serial executor (wrapped in
    :class:`~torchshm.forward.cores.CoresPerRun` with ``cores_per_run``), else a
    :class:`~torchshm.storage.ParallelModel`.

    Raises:
        ValueError: for an unknown executor kind or parameter, or runs that do not fit the
            machine's cores (the message names it).
    """
    from torchshm.storage import ParallelModel
    from torchshm.forward.cores import CoresPerRun, fit_workers
    from torchshm.storage import evaluation_options

    options = evaluation_options(
        executor.kind, executor.folder, executor.n_jobs, executor.params, executor.address,
        executor.jobqueue, executor.cores_per_run, executor.cores_env,
    )
    if options["executor"] is None and options["n_jobs"] == 1:
        if options["cores_per_run"] is None:
            return model
        fit_workers(1, options["cores_per_run"])
        return CoresPerRun(model, options["cores_per_run"], options["cores_env"])
    return ParallelModel(model, **options)


def runs_report(model: object) -> str | None:
    """The run-folder summary of ``model`` or of the model it wraps (``ParallelModel``, a
    cached model): runs by status, folders kept, disk used; None for a model without one."""
    for _ in range(5):
        summary = getattr(model, "runs_summary", None)
        if callable(summary):
            return str(summary())
        model = getattr(model, "model", None)
        if model is None:
            return None
    return None


def _cause(err: BaseException) -> str:
    """The innermost reason of Hydra's instantiation error, in one line."""
    inner = err
    while inner.__cause__ is not None:
        inner = inner.__cause__
    if inner is err:
        text = _first_line(err).split(", set env var HYDRA_FULL_ERROR")[0]
        return text.replace("Error locating target", "cannot import").rstrip(".")
    return f"{type(inner).__name__}: {_first_line(inner)}"


def _first_line(err: BaseException) -> str:
    lines = [line.strip() for line in str(err).splitlines() if line.strip()]
    return lines[0] if lines else type(err).__name__


__all__ = ["instantiate_model", "runs_report", "with_executor"]

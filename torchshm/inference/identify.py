"""``torchshm.identify``: one entry point for every registered method (:mod:`.registry`)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from torchshm.inference.checks import check_fit
from torchshm.inference.posterior import Posterior

if TYPE_CHECKING:
    from torchshm.problem import Problem

from torchshm.inference.method_checks import charge_check
from torchshm.inference.validate import METHODS, check_model_output, runner, validate  # noqa: F401


def identify(
    problem: Problem, method: str = "emulator", seed: int = 0, *, log_dir: str | Path | None = None,
    **options: Any,
) -> Posterior:
    """Infer the posterior of ``problem``'s parameters.

    Args:
        problem: a :class:`~torchshm.Problem`.
        method: ``"emulator"`` (the default: an adaptive emulator of the model, refined in
            batches of concurrent model runs until its stop rule holds), ``"vbmc"`` (PyVBMC,
            the paper's method), ``"emcee"`` (the paper's benchmark: affine-invariant
            ensemble MCMC) or any method registered since
            (:func:`torchshm.inference.registry.register_method`).
        seed: seed of every random draw of the run.
        log_dir: TensorBoard folder written during the run (per VBMC iteration, or every
            ``log_every`` emcee steps), or None.
        **options: method options. VBMC: ``n_samples``, ``start``
            (:class:`~torchshm.inference.start.StartSettings`), ``reuse`` and any PyVBMC option
            (``max_fun_evals``, also under the emulator's name ``max_model_evaluations``,
            ``display``, ...). emcee: ``n_walkers`` (40), ``n_steps`` (2000),
            ``burn``, ``thin``, ``backend_path``, ``log_every``, ``window``, ``moves``.
            emulator (few model runs, in concurrent batches): ``batch_size`` (5),
            ``max_model_evaluations``, ``n_jobs``, ``executor`` and the stop rule's
            ``tv_tol``, ``patience``, ``sd_tol``, ``check_tol``. See ``docs/inference.md``.

    Returns:
        The :class:`Posterior`. A run that did not converge has ``converged = False`` and warns.
        :func:`~torchshm.inference.checks.check_fit` then adds ``post.warnings`` (not converged,
        mass at a prior bound, noise model contradicted by the data; no model run).

    Before any model run, every input is checked (:func:`torchshm.inference.validate.validate`):
    an input that would be refused is refused in one line naming it and the fix, after at most
    one model run (the output's shape and dtype); parallel runs (``n_jobs``, ``executor``) of a
    problem without a store get one in ``log_dir`` (else under ``runs/``), said in a log line.

    Raises:
        ValueError: for an unknown method or option, or an input refused by the checks.
        KeyboardInterrupt, SystemExit: on Ctrl-C, or SIGTERM (exit status 143), the run stops
            at once after one line on stderr; every finished model run is in the problem's
            store, and the same call on the same store resumes.
    """
    from torchshm.inference.registry import resolve_aliases
    from torchshm.storage.interrupt import resumable, store_of

    options = resolve_aliases(method, options)  # e.g. VBMC's max_model_evaluations: max_fun_evals
    validate(problem, method, seed, log_dir, options)
    with resumable(f"identify ({method})", store_of(problem)):
        before = int(problem.n_model_evaluations)
        check_model_output(problem, method, seed, options)
        checked = int(problem.n_model_evaluations) - before  # 0 or 1: counted with the method's
        options = charge_check(method, options, len(problem.names), len(problem.physical_names),
                               checked)
        post = _run(problem, method, seed, log_dir, options)
        post.n_model_evaluations += checked
        post.diagnostics["n_check_evaluations"] = checked
        return check_fit(post)


def _run(problem: Problem, method: str, seed: int, log_dir: str | Path | None,
         options: dict[str, Any]) -> Posterior:
    """Dispatch to the method's runner (see :func:`identify`)."""
    return runner(method)(problem, seed, log_dir=log_dir, **options)

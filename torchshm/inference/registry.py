"""The inference methods of :func:`torchshm.identify`, registered by name as kernels are.

A method is its runner ``run(problem, seed, *, log_dir=None, **options) -> Posterior`` (whose
keyword parameters are the method's options) and what the checks before the first model run
need to know of it: the option values it would refuse later, the first point it evaluates, how
the output check's model run is charged to its budget, and the line that says it did not
converge. Adding a method is one module that calls :func:`register_method` (see
``docs/architecture.md``); the built-in ones are in :mod:`torchshm.inference.methods`.
"""

from __future__ import annotations

import difflib
import importlib
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from torchshm.problem import Problem

Options = dict[str, Any]


@dataclass(frozen=True)
class Method:
    """One inference method.

    Attributes:
        name: the ``method=`` of :func:`torchshm.identify` (and ``method=<name>`` of the CLI).
        runner: the function that runs it, or ``"module:function"`` (imported on first use, so
            registering a method imports none of its libraries).
        has_evidence: whether its posterior has a log evidence (Bayes factors need one).
        pass_through: names the runner's ``**options`` accept (e.g. PyVBMC's options); None
            when any name passes. Only read when the runner takes ``**options``.
        pass_through_doc: where those names are listed, for the refusal of an unknown option.
        check: ``check(options, dim)`` refuses (``ValueError``, :func:`refuse`) option values
            the method would refuse only later; ``options`` holds the runner's defaults
            overridden by the user's, ``dim`` is `D`.
        first_point: ``first_point(problem, seed, options)``: the `D` parameters the method
            evaluates first on a problem without runs (default: the plausible box's centre).
        runs_none: ``runs_none(options)``: whether these options let it run no model at all.
        charge: ``charge(options, dim, n_phys, checked)``: ``options`` with the output check's
            ``checked`` model runs taken from its budget (default: unchanged).
        not_converged: ``not_converged(posterior)``: the ``NOT CONVERGED: ...`` line saying what
            it reported and what to raise (default: a generic line).
        failed_runs: what it does with a failed model run, for the warning that counts them.
        aliases: other names of its options, ``{alias: option}`` (e.g. VBMC's budget under the
            emulator's name, ``max_model_evaluations``, so that one setting serves a sweep over
            methods); :func:`resolve_aliases` renames them before any check.
    """

    name: str
    runner: Callable[..., Any] | str
    has_evidence: bool = False
    pass_through: Callable[[], set[str] | None] | None = None
    pass_through_doc: str = "the options its runner passes on"
    check: Callable[[Options, int], None] | None = None
    first_point: Callable[[Problem, int, Options], np.ndarray] | None = None
    runs_none: Callable[[Options], bool] | None = None
    charge: Callable[[Options, int, int, int], Options] | None = None
    not_converged: Callable[[Any], str] | None = None
    failed_runs: str = "left out"
    aliases: dict[str, str] = field(default_factory=dict, hash=False)  # a Method stays hashable

    def run(self) -> Callable[..., Any]:
        """The runner function (imported when given as ``"module:function"``)."""
        if callable(self.runner):
            return self.runner
        module, name = self.runner.split(":")
        return getattr(importlib.import_module(module), name)


_METHODS: dict[str, Method] = {}


def register_method(method: Method) -> Method:
    """Add ``method`` under its name (a later registration of the same name replaces it)."""
    _METHODS[method.name] = method
    return method


def method_names() -> tuple[str, ...]:
    """Names of the registered methods, in registration order."""
    return tuple(_METHODS)


def get_method(name: object) -> Method:
    """The method called ``name``.

    Raises:
        ValueError: ``identify: unknown method ...`` naming the registered ones (and the
            closest name).
    """
    if name not in _METHODS:
        close = difflib.get_close_matches(str(name), method_names(), n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        raise ValueError(f"identify: unknown method {name!r}{hint}; choose one of {method_names()}")
    return _METHODS[name]  # type: ignore[index]


def find_method(name: object) -> Method | None:
    """The method called ``name``, or None (e.g. a posterior file of a method not registered)."""
    return _METHODS.get(name)  # type: ignore[arg-type]


def resolve_aliases(method: str, options: Options) -> Options:
    """``options`` with ``method``'s aliases (:attr:`Method.aliases`) renamed to their options;
    an alias set to None is dropped (unset), as an unset option is.

    Raises:
        ValueError: for an unknown method (:func:`get_method`), or an alias and its option both
            given with different values.
    """
    aliases = get_method(method).aliases
    if not any(key in options for key in aliases):
        return options
    out = {k: v for k, v in options.items() if k not in aliases}
    for alias, name in aliases.items():
        value = options.get(alias)
        if value is None:
            continue
        if out.get(name) is not None and out[name] != value:
            refuse(method, f"{alias} (method.{alias}) = {value!r} and {name} (method.{name}) = "
                           f"{out[name]!r} name the same setting; give one of them")
        out[name] = value
    return out


def refuse(method: str, text: str) -> None:
    """Raise the one-line refusal of an option value: ``identify: method='<method>': <text>``."""
    raise ValueError(f"identify: method={method!r}: {text}")


def check_walkers(method: str, n_walkers: Any, dim: int) -> None:
    """Refuse an ensemble of fewer than ``2 dim`` walkers (emcee's own rule)."""
    if n_walkers is not None and n_walkers < 2 * dim:
        refuse(method, f"n_walkers (method.n_walkers) must be at least twice the number of parameters "
                       f"(2 x {dim} = {2 * dim}), got {n_walkers}; raise n_walkers")


__all__ = ["Method", "check_walkers", "find_method", "get_method", "method_names", "refuse", "register_method",
           "resolve_aliases"]

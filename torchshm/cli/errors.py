"""One-line error messages for bad input to the command-line tools.

A bad input (a missing or malformed data file, an unknown load case or config option, inverted
bounds) must end with a non-zero exit status and exactly one line on stderr that names the
problem. The library reports such problems as ``ValueError`` (or ``OSError`` for files); Hydra
and OmegaConf as their own exceptions with multi-line messages, which :func:`one_line` folds.
"""

from __future__ import annotations

import os
import shutil
import sys
from contextlib import contextmanager, suppress
from pathlib import Path
from typing import Iterator

from hydra.errors import HydraException, OverrideParseException
from omegaconf.errors import OmegaConfBaseException

#: exceptions that mean "bad input": reported in one line, not as a traceback
INPUT_ERRORS: tuple[type[BaseException], ...] = (
    HydraException,
    OmegaConfBaseException,
    ValueError,
    OSError,
)
#: exit status after a bad input (as argparse does for usage errors)
EXIT_BAD_INPUT = 2


class BadInput(BaseException):
    """A bad input found inside a Hydra job, on its way out to :func:`report_bad_input`.

    It derives from ``BaseException`` so that Hydra's job runner, which catches ``Exception``
    and reports a failed job with extra lines on stderr, lets it pass unchanged. The original
    exception is its ``__cause__``; ``args[0]`` is the one-line message.
    """


@contextmanager
def bad_input_in_job(run_dir: Path | None = None) -> Iterator[None]:
    """Inside a Hydra task function: re-raise an :data:`INPUT_ERRORS` exception as :class:`BadInput`.

    Args:
        run_dir: the job's run folder; a refused run removes it when it holds nothing but
            Hydra's ``.hydra/`` record and empty log files (see :func:`discard_empty_run`).
    """
    try:
        yield
    except INPUT_ERRORS as err:
        if run_dir is not None:
            discard_empty_run(run_dir)
        raise BadInput(one_line(err)) from err


def discard_empty_run(run_dir: Path) -> bool:
    """Remove a refused run's folder if nothing was written in it but ``.hydra/`` and empty
    logs, and then its parent and grandparent if they are left empty. Returns whether the folder
    was removed."""
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        return False
    for path in run_dir.rglob("*"):
        inside_hydra = path.relative_to(run_dir).parts[0] == ".hydra"
        if path.is_file() and not inside_hydra and path.stat().st_size > 0:
            return False
    shutil.rmtree(run_dir, ignore_errors=True)
    for parent in run_dir.parents[:2]:  # only empty ones: e.g. runs/<day>/ of this one run
        with suppress(OSError):
            parent.rmdir()
    return not run_dir.exists()


def one_line(err: BaseException) -> str:
    """``err`` as one line: its first line, Hydra's option list folded in, then its cause.

    ``In 'config': Could not find 'kernel/foo'`` + ``Available options in 'kernel':`` + one
    option a line becomes ``... 'kernel/foo'; available options in 'kernel': a, b, c``; an
    OmegaConf cause (``Invalid value 'foo', expected one of [...]``) is appended after a colon.
    """
    lines = [line.strip() for line in str(err).splitlines()]
    parts: list[str] = []
    options: list[str] = []
    for line in lines:
        if not line or line.startswith(("Config search path", "provider=", "To append")):
            continue
        if line.startswith("Available options"):
            options = [line[0].lower() + line[1:]]
        elif options:
            options.append(line)
        else:
            parts.append(line)
    text = "; ".join(parts[:1]).rstrip(".") or type(err).__name__
    if isinstance(err, OverrideParseException):
        text = f"cannot parse override {err.override!r}: {text}"
    if options:
        text += f"; {options[0]} {', '.join(options[1:])}"
    cause = err.__cause__
    if isinstance(cause, OmegaConfBaseException):
        first = next((c.strip() for c in str(cause).splitlines() if c.strip()), "")
        if first:
            text += f": {first}"
    if isinstance(err, FileNotFoundError) and err.filename and str(err.filename) not in text:
        text += f": {err.filename}"
    return text


@contextmanager
def report_bad_input(prog: str) -> Iterator[None]:
    """Turn a :class:`BadInput` or an :data:`INPUT_ERRORS` exception into
    ``<prog>: error: <one line>`` on stderr and exit status 2.

    With ``HYDRA_FULL_ERROR=1`` in the environment the exception propagates with its
    traceback instead. Hydra's own error printing is bypassed by setting ``HYDRA_FULL_ERROR``
    while the block runs, so that every error reaches this handler.
    """
    previous = os.environ.get("HYDRA_FULL_ERROR")
    full_error = previous == "1"
    os.environ["HYDRA_FULL_ERROR"] = "1"
    try:
        yield
    except BrokenPipeError:  # output piped into e.g. `head`: not an input problem
        sys.stderr.close()
        raise SystemExit(1) from None
    except (*INPUT_ERRORS, BadInput) as err:
        if full_error:
            raise
        message = err.args[0] if isinstance(err, BadInput) else one_line(err)
        print(f"{prog}: error: {message}", file=sys.stderr, flush=True)
        raise SystemExit(EXIT_BAD_INPUT) from None
    finally:
        if previous is None:
            os.environ.pop("HYDRA_FULL_ERROR", None)
        else:
            os.environ["HYDRA_FULL_ERROR"] = previous


__all__ = [
    "EXIT_BAD_INPUT", "INPUT_ERRORS", "BadInput", "bad_input_in_job", "discard_empty_run", "one_line",
    "report_bad_input",
]

"""Template → run → read: a forward model for any program driven by an input deck.

Most FE programs (CalculiX, Code_Aster, Abaqus, DIANA, OpenSees Tcl) read an input file and
write a result file. :class:`TemplateModel` fills the parameters into a deck template, runs the
program in a fresh work folder and reads the strains at the sensors from the result file with
a *reader*; everything else (work folders, ``index.csv``, timeouts, what is kept, the
evaluation store's identity) is :class:`~torchshm.forward.ExternalModel`'s.

Placeholders, ``style="format"`` (Python's ``str.format``): ``{E_Pa}`` or with a format
specification ``{E_Pa:.6e}``; write a literal brace as ``{{``. ``style="template"``
(``string.Template``): ``$E_Pa`` or ``${E_Pa}``; a literal ``$`` as ``$$`` (for decks full of
braces, e.g. Tcl). The values are the parameters by name, or what ``values(parameters)``
returns (unit conversions, ``10 ** log10_k``, quantities derived from several parameters).

A reader is any picklable callable ``reader(folder, x, loads) -> strains`` `L x n` [µε]
raising ``ValueError`` when the result file is unusable, e.g.
:class:`~torchshm.forward.calculix.CalculixStrain`.
"""

from __future__ import annotations

import functools
import hashlib
import os
import string
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from torchshm.forward.external import DEFAULT_MAX_OUTPUT_BYTES, ExternalModel, ExternalModelError

Reader = Callable[[Path, np.ndarray, np.ndarray], np.ndarray]
STYLES = ("format", "template")


class TemplateModel(ExternalModel):
    """A forward model that fills a deck template, runs a program and reads its results.

    Args:
        deck: the deck template file (read once, here).
        command: the program as a list of arguments, e.g. ``["ccx", "-i", "slab"]``, run in
            the run's folder (or a shell line as a string).
        reader: ``reader(folder, x, loads)`` → strains [µε] `L x n` from the result file.
        x: sensor positions `n` [m] (values, ``{start, stop, num}`` or a ``.csv``/``.npy`` file).
        loads: load cases `L`, given as ``x`` is; the deck has one analysis step per load case.
        names: the parameter names `P`, in model order (the placeholders unless ``values``).
        values: ``values({name: value}) -> {placeholder: value}``; None: the parameters.
        deck_name: the deck's name in the run folder; None: the template's name without a
            ``.template``/``.tmpl`` suffix.
        files: files the deck needs as they are (a mesh, included decks), linked into each
            run folder under their names.
        style: ``"format"`` (``{name}``) or ``"template"`` (``$name``).
        **kwargs: the other arguments of :class:`ExternalModel` (``timeout``, ``workdir``,
            ``identity``, ``keep``, ``kill_grace``, ``max_output_bytes``).

    Raises:
        ValueError: before any run, on a missing template or file, a ``deck_name`` that is not a
            plain file name, an unknown style, or (with ``values`` None) a placeholder that is
            not in ``names``.
    """

    def __init__(
        self,
        deck: str | Path,
        command: str | Sequence[str],
        reader: Reader,
        x: object,
        loads: object,
        names: Sequence[str],
        *,
        values: Callable[[dict[str, float]], Mapping[str, Any]] | None = None,
        deck_name: str | None = None,
        files: Sequence[str | Path] = (),
        style: str = "format",
        timeout: float | None = None,
        workdir: str | Path | None = None,
        identity: str | None = None,
        keep: str = "failed",
        kill_grace: float = 5.0,
        max_output_bytes: int | None = DEFAULT_MAX_OUTPUT_BYTES,
    ) -> None:
        path = Path(deck).expanduser()
        if not path.is_file():
            raise ValueError(f"deck template {path} does not exist (a relative path is relative to {Path.cwd()})")
        if style not in STYLES:
            raise ValueError(f"style must be one of {', '.join(STYLES)}, got {style!r}")
        self.deck_text, self.style, self.reader, self.values = path.read_text(), style, reader, values
        self.deck_name = deck_name or (path.stem if path.suffix in (".template", ".tmpl") else path.name)
        if Path(self.deck_name).name != self.deck_name or self.deck_name in (".", ".."):
            raise ValueError(f"deck_name must be a file name (it is written into the run folder), got {deck_name!r}")
        self.files = [Path(f).expanduser().resolve() for f in files]
        missing = [f for f in self.files if not f.is_file()]
        if missing:
            raise ValueError(f"files: {missing[0]} does not exist")
        if values is None:
            unknown = sorted(set(placeholders(self.deck_text, style)) - set(names))
            if unknown:
                raise ValueError(f"deck template {path.name}: placeholder(s) {unknown} are not parameters "
                                 f"{list(names)}; pass values=... to compute them")
        super().__init__(command, x, loads, timeout, workdir, names=names, identity=identity,
                         keep=keep, kill_grace=kill_grace, max_output_bytes=max_output_bytes)

    def fill(self, theta: np.ndarray) -> str:
        """The deck for parameters `P` (``ValueError`` naming a placeholder without a value)."""
        parameters = {name: float(v) for name, v in zip(self.names or [], theta)}
        mapping = dict(self.values(parameters)) if self.values is not None else parameters
        try:
            if self.style == "template":
                return string.Template(self.deck_text).substitute(mapping)
            return self.deck_text.format(**mapping)
        except KeyError as missing:
            raise ValueError(f"deck placeholder {missing} has no value (values: {sorted(mapping)})") from None

    def _prepare(self, folder: Path, theta: np.ndarray, names: list[str]) -> None:
        super()._prepare(folder, theta, names)
        try:
            (folder / self.deck_name).write_text(self.fill(theta))
        except ValueError as exc:
            raise ExternalModelError(f"{exc} (work folder {folder})") from None
        for file in self.files:
            os.symlink(file, folder / file.name)

    def _read(self, folder: Path) -> np.ndarray:
        strain = np.asarray(self.reader(folder, self.x.numpy(), self.loads.numpy()), dtype=np.float64)
        expected = (len(self.loads), len(self.x))
        if strain.shape != expected:
            raise ValueError(f"the reader returned strains of shape {strain.shape}, expected (L, n) = {expected}")
        if not np.isfinite(strain).all():
            raise ValueError(f"the reader returned {int((~np.isfinite(strain)).sum())} NaN or inf strains")
        return strain

    def _default_identity(self) -> str:
        """A hash of the command, names, x, loads, the deck, the reader, ``values`` and the
        contents of ``files``: changing any of them is a new model for the store."""
        digest = hashlib.sha256(super()._default_identity().encode())
        digest.update(self.deck_text.encode())
        digest.update(_describe(self.reader).encode())
        digest.update(_describe(self.values).encode())
        for file in self.files:
            digest.update(file.name.encode())
            digest.update(file.read_bytes())
        return f"TemplateModel-{digest.hexdigest()[:16]}"


def _describe(obj: object) -> str:
    """A description of a callable that is the same in every process (no memory address)."""
    if isinstance(obj, functools.partial) and not obj.args and not obj.keywords:
        return _describe(obj.func)  # Hydra's _partial_: true without arguments is the function
    if isinstance(obj, functools.partial):
        return f"partial({_describe(obj.func)}, {obj.args!r}, {sorted(obj.keywords.items())!r})"
    if hasattr(obj, "__qualname__"):
        return f"{getattr(obj, '__module__', '')}.{obj.__qualname__}"
    text = repr(obj)
    if " at 0x" in text and hasattr(obj, "__dict__"):  # the default repr: use the attributes
        text = f"{type(obj).__module__}.{type(obj).__qualname__}{sorted(vars(obj).items())!r}"
    return text


def placeholders(text: str, style: str = "format") -> list[str]:
    """The placeholder names used in a deck template, in order of first use."""
    if style == "template":
        names = [m.group("named") or m.group("braced") for m in string.Template.pattern.finditer(text)]
    else:
        names = [field.split(".")[0].split("[")[0] for _, field, _, _ in string.Formatter().parse(text)
                 if field is not None]
    return list(dict.fromkeys(n for n in names if n))


__all__ = ["STYLES", "TemplateModel", "placeholders"]

"""TemplateModel: a deck template filled per θp, the program run in its folder, a reader."""

from __future__ import annotations

import functools
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

from torchshm.forward import ExternalModelError, TemplateModel, model_identity, placeholders

X, LOADS = np.array([0.0, 0.5, 1.0]), np.array([1.0, 2.0])
#: the "FE program": reads deck.inp ("key value" lines) and table.dat, writes result.txt with
#: strain = scale * load * (x + E)
PROGRAM = (
    "vals = dict(line.split() for line in open('deck.inp') if line.strip() and not line.startswith('*'))\n"
    "scale = float(open('table.dat').read())\n"
    "with open('result.txt', 'w') as out:\n"
    "    for load in (1.0, 2.0):\n"
    "        out.write(' '.join(repr(scale * load * (x + float(vals['E']))) for x in (0.0, 0.5, 1.0)) + '\\n')\n"
)


def read_result(folder: Path, x: np.ndarray, loads: np.ndarray) -> np.ndarray:
    """The test program's reader: one row of strains per load case."""
    path = folder / "result.txt"
    if not path.is_file():
        raise ValueError("no result.txt")
    return np.loadtxt(path, ndmin=2)


def double(parameters: dict[str, float], factor: float = 2.0) -> dict[str, float]:
    return {"E_twice": factor * parameters["E"], "k": 10 ** parameters["log10_k"]}


def _setup(tmp_path: Path, deck: str, name: str = "deck.inp.template") -> tuple[Path, list[str], Path]:
    (tmp_path / "program.py").write_text(PROGRAM)
    (tmp_path / name).write_text(deck)
    (tmp_path / "table.dat").write_text("3.0")
    return tmp_path / name, [sys.executable, str(tmp_path / "program.py")], tmp_path / "table.dat"


@pytest.mark.parametrize(("style", "deck"), [
    ("format", "** {{literal}}\nE {E:.6e}\nk {log10_k}\n"),
    ("template", "** {literal} $$5\nE ${E}\nk $log10_k\n"),
])
def test_filled_deck_runs_and_is_read(tmp_path: Path, style: str, deck: str) -> None:
    template, command, table = _setup(tmp_path, deck)
    model = TemplateModel(template, command, read_result, X, LOADS, ["E", "log10_k"], files=[table],
                          style=style, workdir=tmp_path / "runs", keep="all")
    out = model(torch.tensor([[2.0, 6.0], [4.0, 7.0]], dtype=torch.float64))
    expected = 3.0 * LOADS[:, None] * (X[None, :] + np.array([2.0, 4.0])[:, None, None])
    np.testing.assert_allclose(out.numpy(), expected, rtol=1e-6)
    first = sorted((tmp_path / "runs").glob("run-*"))[0]
    assert (first / "deck.inp").read_text().splitlines()[0] == "** {literal}" + (" $5" if style == "template" else "")
    assert (first / "table.dat").is_symlink() and (first / "params.json").is_file()


def test_values_function_and_its_partial(tmp_path: Path) -> None:
    template, command, table = _setup(tmp_path, "E {E_twice}\nk {k:.3e}\n")
    model = TemplateModel(template, command, read_result, X, LOADS, ["E", "log10_k"], files=[table],
                          values=functools.partial(double, factor=0.5), workdir=tmp_path / "runs")
    assert model.fill(np.array([4.0, 6.0])) == "E 2.0\nk 1.000e+06\n"
    np.testing.assert_allclose(model(torch.tensor([4.0, 6.0]))[0].numpy(), 3.0 * (X + 2.0))
    other = TemplateModel(template, command, read_result, X, LOADS, ["E", "log10_k"], files=[table],
                          values=functools.partial(double, factor=0.5))
    assert model_identity(other) == model_identity(model)
    doubled = TemplateModel(template, command, read_result, X, LOADS, ["E", "log10_k"], files=[table],
                            values=double)
    assert model_identity(doubled) != model_identity(model)


def test_identity_follows_the_deck_and_the_files(tmp_path: Path) -> None:
    template, command, table = _setup(tmp_path, "E {E}\n")
    make = lambda: TemplateModel(template, command, read_result, X, LOADS, ["E"], files=[table])  # noqa: E731
    first = model_identity(make())
    assert first.startswith("TemplateModel-") and model_identity(make()) == first
    table.write_text("4.0")
    second = model_identity(make())
    template.write_text("E {E}\n** mesh v2\n")
    assert len({first, second, model_identity(make())}) == 3


def test_inputs_refused_before_any_run(tmp_path: Path) -> None:
    template, command, table = _setup(tmp_path, "E {E}\nk {k}\n")
    with pytest.raises(ValueError, match=r"placeholder\(s\) \['k'\] are not parameters \['E'\]; pass values"):
        TemplateModel(template, command, read_result, X, LOADS, ["E"])
    with pytest.raises(ValueError, match="deck template .*nosuch.inp does not exist"):
        TemplateModel(tmp_path / "nosuch.inp", command, read_result, X, LOADS, ["E", "k"])
    with pytest.raises(ValueError, match="files: .*mesh.inp does not exist"):
        TemplateModel(template, command, read_result, X, LOADS, ["E", "k"], files=[tmp_path / "mesh.inp"])
    with pytest.raises(ValueError, match="deck_name must be a file name"):
        TemplateModel(template, command, read_result, X, LOADS, ["E", "k"], deck_name="../deck.inp")
    with pytest.raises(ValueError, match="style must be one of format, template"):
        TemplateModel(template, command, read_result, X, LOADS, ["E", "k"], style="jinja")
    assert placeholders("a {E:.3f} {k[0]} {{x}} {E}") == ["E", "k"]
    assert placeholders("a $E ${k} $$x", "template") == ["E", "k"]


def test_failures_are_external_model_errors(tmp_path: Path) -> None:
    template, command, table = _setup(tmp_path, "E {E_twice}\n")
    bad_values = TemplateModel(template, command, read_result, X, LOADS, ["E"], values=lambda p: {"E": 1.0},
                               workdir=tmp_path / "runs")
    with pytest.raises(ExternalModelError, match=r"deck placeholder 'E_twice' has no value \(values: \['E'\]\)"):
        bad_values(torch.tensor([1.0]))
    no_table = TemplateModel(template, command, read_result, X, LOADS, ["E"], values=lambda p: {"E_twice": 1.0},
                             workdir=tmp_path / "runs")
    with pytest.raises(ExternalModelError, match="program exited with status 1"):
        no_table(torch.tensor([1.0]))
    wrong_shape = TemplateModel(template, command, lambda f, x, loads: np.zeros((1, 3)), X, LOADS, ["E"],
                                values=lambda p: {"E_twice": 1.0}, files=[table], workdir=tmp_path / "runs")
    with pytest.raises(ExternalModelError, match=r"reader returned strains of shape \(1, 3\), expected \(L, n\) = \(2, 3\)"):
        wrong_shape(torch.tensor([1.0]))
    assert len(list((tmp_path / "runs").glob("run-*"))) == 3  # failed runs keep their folders

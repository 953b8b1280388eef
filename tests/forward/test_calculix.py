"""Reading CalculiX ``.frd`` strains at sensor points; the CalculiX slab against beam theory."""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

from torchshm.forward import CalculixStrain, read_frd

ROOT = Path(__file__).resolve().parents[2]

#: a hand-written .frd: 4 nodes (short format, I5), two strain blocks; negative values run
#: into each other as CalculiX writes them
FRD = """\
    1C
    1UUSER
    2C                             4                                     0
 -1    1 0.00000E+00 0.00000E+00 0.00000E+00
 -1    2 1.00000E+00 0.00000E+00 0.00000E+00
 -1    3 2.00000E+00 0.00000E+00 0.00000E+00
 -1    4 1.00000E+00 1.00000E+00 0.00000E+00
 -3
    3C                             1                                     0
 -1    1    1    0    1
 -2    1    2    3    4
 -3
  100CL  101 1.000000000             4                     0    1           0
 -4  TOSTRAIN    6    1
 -5  EXX         1    4    1    1
 -5  EYY         1    4    2    2
 -1    1 1.00000E-04-2.00000E-05
 -1    2 2.00000E-04-4.00000E-05
 -1    3-1.00000E-04 5.00000E-05
 -1    4 9.00000E-04 0.00000E+00
 -3
  100CL  102 2.000000000             4                     0    2           0
 -4  TOSTRAIN    6    1
 -5  EXX         1    4    1    1
 -5  EYY         1    4    2    2
 -1    1 0.00000E+00 0.00000E+00
 -1    2 1.00000E-05 0.00000E+00
 -1    3 2.00000E-05 0.00000E+00
 -1    4 0.00000E+00 0.00000E+00
 -3
9999
"""


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    (tmp_path / "job.frd").write_text(FRD)
    return tmp_path


def test_read_frd_nodes_and_blocks(folder: Path) -> None:
    nodes, blocks = read_frd(folder / "job.frd")
    assert sorted(nodes) == [1, 2, 3, 4] and nodes[4].tolist() == [1.0, 1.0, 0.0]
    assert [(name, comps) for name, comps, _ in blocks] == [("TOSTRAIN", ["EXX", "EYY"])] * 2
    assert blocks[0][2][3].tolist() == [-1e-4, 5e-5]


def test_strains_interpolated_along_the_line_of_nodes(folder: Path) -> None:
    reader = CalculixStrain()  # job.frd, EXX, nodes on y = z = 0: 1, 2, 3 (not 4)
    out = reader(folder, np.array([0.0, 0.5, 1.0, 1.75]), np.array([1.0, 2.0]))
    np.testing.assert_allclose(out, [[100.0, 150.0, 200.0, -25.0], [0.0, 5.0, 10.0, 17.5]], atol=1e-9)
    eyy = CalculixStrain(component="EYY")(folder, np.array([2.0]), np.array([1.0, 2.0]))
    np.testing.assert_allclose(eyy, [[50.0], [0.0]])


@pytest.mark.parametrize(("reader", "x", "loads", "message"), [
    (CalculixStrain(), [0.0], [1.0], r"2 strain blocks \(TOSTRAIN/STRAIN\), expected one per load case \(1\)"),
    (CalculixStrain(), [0.0, 2.5], [1.0, 2.0], r"sensors span 0..2.5 m, the fibre's nodes 0..2 m"),
    (CalculixStrain(line=(5.0, 0.0)), [0.0], [1.0, 2.0], r"0 node\(s\) on the line \(5.0, 0.0\)"),
    (CalculixStrain(component="EZZ"), [0.0], [1.0, 2.0], r"no component EZZ \(found \['EXX', 'EYY'\]\)"),
    (CalculixStrain(file="other.frd"), [0.0], [1.0], "no result file other.frd was written"),
])
def test_unusable_results_are_named(folder: Path, reader: CalculixStrain, x: list, loads: list, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        reader(folder, np.array(x), np.array(loads))


def test_calculix_slab_without_middle_support_is_a_simply_supported_beam(tmp_path: Path) -> None:
    """k_B = 1 N/m: the 20 m strip under 100 kN at 4 m; bottom strain M (h/2) / (E I) within
    0.1 % of the largest strain away from the load and the supports (measured 0.002 %)."""
    assert shutil.which("ccx"), "CalculiX is not installed: bash scripts/install.sh (as root) or apt-get install calculix-ccx"
    sys.path.insert(0, str(ROOT))
    from examples.calculix_slab.slab import calculix_slab

    model = calculix_slab(workdir=tmp_path, keep="none")
    strain = model(torch.tensor([34.0, 0.0], dtype=torch.float64))[0].numpy()
    x = model.x.numpy()
    moment = np.where(x < 4.0, 80e3 * x, 20e3 * (20.0 - x))  # N·m
    expected = 1e6 * moment * 0.2 / (34e9 * 0.4**3 / 12)
    away = ((x > 1.0) & (x < 3.0)) | ((x > 5.5) & (x < 19.0))
    assert np.abs(strain - expected)[away].max() < 1e-3 * expected.max()
    assert list(tmp_path.glob("run-*")) == []

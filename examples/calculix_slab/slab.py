"""The CalculiX two-span slab as a torchshm forward model: template → ``ccx`` → ``.frd`` reader.

Everything the model needs is in this folder: the deck template ``slab.inp.template`` (the
parameters as ``{placeholders}``), the mesh ``mesh.inp`` (written by ``make_mesh.py``) and
:func:`deck_values`, which turns the parameters into the deck's values. The config
``conf/model/calculix_slab.yaml`` builds the same model with Hydra.
"""

from __future__ import annotations

from pathlib import Path

import torchshm

HERE = Path(__file__).resolve().parent
NAMES = ("E", "log10_k_B")  # Young's modulus [GPa], log10 of the middle support's stiffness [N/m]
LOADS = (4.0, 8.0, 12.0, 16.0)  # positions of the 100 kN line load [m], one *STEP each
X = {"start": 0.0, "stop": 20.0, "num": 201}  # the fibre: every 0.1 m along the bottom edge [m]


def deck_values(parameters: dict[str, float]) -> dict[str, float]:
    """The deck's placeholders from the parameters: ``E_Pa`` [Pa] and ``k_node`` [N/m], the
    stiffness of each of the two springs under the middle support (half the support's)."""
    return {"E_Pa": parameters["E"] * 1e9, "k_node": 10.0 ** parameters["log10_k_B"] / 2.0}


def calculix_slab(workdir: str | Path = "runs/calculix_slab/fe", keep: str = "failed",
                  timeout: float = 120.0) -> torchshm.TemplateModel:
    """The slab model: ``ccx -i slab`` in a fresh folder per θp = (E [GPa], log10 k_B [N/m]),
    strains ``EXX`` [µε] at 201 points of the bottom edge for the 4 load cases."""
    reader = torchshm.CalculixStrain(file="slab.frd", component="EXX", axis=0, line=(0.0, 0.0))
    return torchshm.TemplateModel(
        HERE / "slab.inp.template", ["ccx", "-i", "slab"], reader, x=X, loads=LOADS, names=NAMES,
        values=deck_values, files=[HERE / "mesh.inp"], workdir=workdir, keep=keep, timeout=timeout,
    )

"""Write ``mesh.inp``: the nodes, elements and node sets of the two-span slab strip (CalculiX).

    python examples/calculix_slab/make_mesh.py      # from the repository root

A 20 m x 1 m x 0.4 m strip, C3D8I bricks (incompatible modes: good in bending with few elements
through the thickness), 0.1 m long, 1 across the width, 2 through the thickness: 1206 nodes,
400 elements. Node sets: the supports ``SUP_A`` (x = 0), ``SUP_B`` (x = 10 m, on a spring),
``SUP_C`` (x = 20 m) on the bottom face; ``FIBRE``, the bottom edge y = 0, z = 0 (the fibre,
one node every 0.1 m); ``LOAD_<a>``, the top nodes at x = a for each load position a [m].
Element set ``SPRING_B``: one vertical spring to ground (``SPRING1``) under each ``SUP_B`` node.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

LENGTH, WIDTH, DEPTH = 20.0, 1.0, 0.4  # m
NX, NZ = 200, 2  # elements along the strip and through the depth
LOADS = (4.0, 8.0, 12.0, 16.0)  # load positions [m]


def node(i: int, j: int, k: int) -> int:
    """Number of the node at grid index i (along x), j (0/1 across y), k (up z)."""
    return 1 + i + (NX + 1) * (j + 2 * k)


def mesh() -> str:
    xs, zs = np.linspace(0.0, LENGTH, NX + 1), np.linspace(0.0, DEPTH, NZ + 1)
    lines = ["** two-span slab strip: written by make_mesh.py", "*NODE, NSET=NALL"]
    lines += [f"{node(i, j, k)}, {x:.6g}, {y:.6g}, {z:.6g}"
              for k, z in enumerate(zs) for j, y in enumerate((0.0, WIDTH)) for i, x in enumerate(xs)]
    lines.append("*ELEMENT, TYPE=C3D8I, ELSET=SLAB")
    for k in range(NZ):
        for i in range(NX):
            corners = [node(i, 0, k), node(i + 1, 0, k), node(i + 1, 1, k), node(i, 1, k)]
            corners += [n + 2 * (NX + 1) for n in corners]  # the same four one layer up
            lines.append(f"{1 + i + NX * k}, " + ", ".join(map(str, corners)))
    lines.append("*ELEMENT, TYPE=SPRING1, ELSET=SPRING_B")  # the middle support: springs to ground
    lines += [f"{9001 + j}, {node(NX // 2, j, 0)}" for j in (0, 1)]
    sets = {"SUP_A": [node(0, j, 0) for j in (0, 1)], "SUP_B": [node(NX // 2, j, 0) for j in (0, 1)],
            "SUP_C": [node(NX, j, 0) for j in (0, 1)], "FIX_X": [node(0, 0, 0)],
            "FIX_Y": [node(0, 0, 0), node(NX, 0, 0)], "FIBRE": [node(i, 0, 0) for i in range(NX + 1)]}
    sets.update({f"LOAD_{a:g}": [node(round(a / LENGTH * NX), j, NZ) for j in (0, 1)] for a in LOADS})
    for name, ids in sets.items():
        lines.append(f"*NSET, NSET={name}")
        lines += [", ".join(map(str, ids[a:a + 8])) + "," for a in range(0, len(ids), 8)]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    path = Path(__file__).resolve().parent / "mesh.inp"
    path.write_text(mesh())
    print(f"wrote {path}")

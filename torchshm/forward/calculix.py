"""Reading CalculiX results: nodal strains from the ``.frd`` file at the sensor positions.

Why ``.frd`` and not ``.dat``: ``*EL PRINT, E`` writes strains at integration points (their
coordinates are not in the ``.dat`` file) and ``*NODE PRINT`` has no strains, whereas
``*EL FILE, E`` writes ``.frd`` strains at the nodes (CalculiX extrapolates them from the
integration points and averages over the elements that share a node), with the node
coordinates in the same file. The sensors are then points on a line of nodes (a fibre glued
along the bottom face of a solid, or along a shell's face with ``OUTPUT=3D``), and each
sensor's strain is interpolated linearly between the two nodes on either side. Put nodes at
the sensor positions where you can; ``*EL FILE, NSET=<the fibre's nodes>`` keeps the file
small. Each ``*STEP`` (one per load case, in the order of ``loads``) adds one result block.

Deck::

    *STEP
    *STATIC
    *CLOAD, OP=NEW
    LOAD_4, 3, -1.e5
    *EL FILE, NSET=FIBRE
    E
    *END STEP
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

#: names of the total-strain block in ``.frd`` files (CalculiX >= 2.17 writes ``TOSTRAIN``)
STRAIN_BLOCKS = ("TOSTRAIN", "STRAIN")


def read_frd(path: str | Path) -> tuple[dict[int, np.ndarray], list[tuple[str, list[str], dict[int, np.ndarray]]]]:
    """Nodes and result blocks of an ASCII ``.frd`` file.

    Returns:
        ``(nodes, blocks)``: ``nodes`` maps node number to its coordinates `3`; ``blocks`` is a
        list, in file order, of ``(name, components, values)`` with ``values`` mapping node
        number to the block's components `C` (e.g. ``("TOSTRAIN", ["EXX", ...], {...})``).

    Raises:
        ValueError: if the file is missing or is not an ASCII ``.frd`` file.
    """
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"no result file {path.name} was written")
    nodes: dict[int, np.ndarray] = {}
    blocks: list[tuple[str, list[str], dict[int, np.ndarray]]] = []
    target: dict[int, np.ndarray] | None = None
    width = 10
    with open(path, errors="replace") as handle:
        for line in handle:
            key = line[:3].strip() if line.startswith(" -") else (line.split() or [""])[0]
            if key in ("2C", "100CL"):
                fields = line.split()
                width = 10 if fields and fields[-1] == "1" else 5  # long or short format
                target = nodes if key == "2C" else None
            elif key == "-4":
                blocks.append((line[5:13].strip(), [], {}))
                target = blocks[-1][2]
            elif key == "-5" and blocks:
                blocks[-1][1].append(line[5:13].strip())
            elif key == "-1" and target is not None:
                number, values = int(line[3:3 + width]), line[3 + width:].rstrip("\n")
                target[number] = np.array([float(values[i:i + 12]) for i in range(0, len(values) - 11, 12)])
            elif key in ("-3", "3C"):
                target = None
    if not nodes:
        raise ValueError(f"{path.name} is not an ASCII .frd file with nodes")
    return nodes, blocks


@dataclass(frozen=True)
class CalculixStrain:
    """Read strains [µε] `L x n` at sensors on a line of nodes from a CalculiX ``.frd`` file.

    A reader for :class:`~torchshm.forward.TemplateModel`: ``reader(folder, x, loads)``.

    Args:
        file: the ``.frd`` file in the run folder (``<job>.frd`` for ``ccx -i <job>``).
        component: the strain component, e.g. ``EXX`` (along a fibre on the x axis).
        axis: the coordinate (0, 1, 2 = x, y, z) the sensor positions ``x`` [m] are measured on.
        line: the other two coordinates [m] of the fibre (in the order of the remaining axes).
        tol: nodes within ``tol`` [m] of ``line`` belong to the fibre.
        scale: factor from the file's strain to µε (1e6 for strain in m/m).
        blocks: names of the strain block; the i-th block found is load case i.

    Raises:
        ValueError: (when called) if the file is missing, has not one strain block per load
            case, no nodes on the line, or sensors outside the nodes' span.
    """

    file: str = "job.frd"
    component: str = "EXX"
    axis: int = 0
    line: Sequence[float] = field(default=(0.0, 0.0))
    tol: float = 1e-6
    scale: float = 1e6
    blocks: Sequence[str] = STRAIN_BLOCKS

    def __post_init__(self) -> None:  # lists from a config equal tuples from Python (same repr, same identity)
        object.__setattr__(self, "line", tuple(float(v) for v in self.line))
        object.__setattr__(self, "blocks", tuple(str(b) for b in self.blocks))

    def __call__(self, folder: Path, x: np.ndarray, loads: np.ndarray) -> np.ndarray:
        nodes, blocks = read_frd(Path(folder) / self.file)
        ids, along = self._fibre(nodes)
        found = [(comps, values) for name, comps, values in blocks if name in self.blocks]
        if len(found) != len(loads):
            raise ValueError(f"{self.file}: {len(found)} strain blocks ({'/'.join(self.blocks)}), "
                             f"expected one per load case ({len(loads)}); one *STEP with *EL FILE E each")
        if along[0] - self.tol > x.min() or along[-1] + self.tol < x.max():
            raise ValueError(f"{self.file}: sensors span {x.min():g}..{x.max():g} m, the fibre's nodes "
                             f"{along[0]:g}..{along[-1]:g} m")
        out = np.empty((len(loads), len(x)))
        for row, (comps, values) in enumerate(found):
            if self.component not in comps:
                raise ValueError(f"{self.file}: no component {self.component} (found {comps})")
            try:
                strain = np.array([values[i][comps.index(self.component)] for i in ids])
            except KeyError as missing:
                raise ValueError(f"{self.file}: no strain at fibre node {missing}; "
                                 "does *EL FILE's NSET hold every fibre node?") from None
            out[row] = self.scale * np.interp(x, along, strain)
        return out

    def _fibre(self, nodes: dict[int, np.ndarray]) -> tuple[list[int], np.ndarray]:
        """Numbers and positions along ``axis`` of the nodes on ``line``, sorted by position."""
        others = [a for a in range(3) if a != self.axis]
        ids = np.array(list(nodes))
        xyz = np.stack([nodes[i] for i in ids])
        on_line = np.all(np.abs(xyz[:, others] - np.asarray(self.line, dtype=float)) <= self.tol, axis=1)
        if on_line.sum() < 2:
            raise ValueError(f"{self.file}: {int(on_line.sum())} node(s) on the line {tuple(self.line)} "
                             f"(coordinates {others}); the fibre needs at least 2")
        order = np.argsort(xyz[on_line, self.axis], kind="stable")
        return [int(i) for i in ids[on_line][order]], xyz[on_line, self.axis][order]


__all__ = ["CalculixStrain", "STRAIN_BLOCKS", "read_frd"]

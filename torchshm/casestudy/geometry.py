"""Geometry of bridge 705 as a 2-D frame: deck, piers, supports, sensors and truck loads.

The deck is a continuous beam along x from the left abutment (x = 0) to the right one
(x = ``length``), with its axis at z = 0; the piers hang below it at ``length * k / n_spans``
(k = 1 .. n_spans - 1), monolithic with the deck at the top and fixed in translation at the
base, where the rotation is free (``"hinged"``), fixed (``"fixed"``) or held by a rotational
spring K_r (``"spring"``). The left abutment holds the deck vertically and horizontally, the
right one vertically. Coordinates inside the frame are in mm, positions given to and returned
by this module in m.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
import torch
from torch import Tensor

from torchshm.casestudy.frame import Frame, bottom_strain_operator, dof

PierBase = Literal["hinged", "fixed", "spring"]

#: tolerance [m] when matching a position to a deck node
NODE_TOL = 1e-6


@dataclass
class BridgeMesh:
    """A frame model of the bridge with the bookkeeping that maps positions to nodes.

    Attributes:
        frame: the frame (N, mm).
        deck_x: `n_deck` positions of the deck nodes [m], ascending; deck node i is frame node i.
        pier_base_rotations: `n_piers` indices of the rotation dof at each pier base.
    """

    frame: Frame
    deck_x: np.ndarray
    pier_base_rotations: Tensor

    def deck_node(self, x: np.ndarray) -> np.ndarray:
        """Indices of the deck nodes at positions `x` [m]; ValueError if one is not a node."""
        x = np.atleast_1d(np.asarray(x, dtype=np.float64))
        index = np.clip(np.searchsorted(self.deck_x, x), 1, self.deck_x.size - 1)
        closer_left = np.abs(self.deck_x[index - 1] - x) < np.abs(self.deck_x[index] - x)
        index = np.where(closer_left, index - 1, index)
        off = np.abs(self.deck_x[index] - x) > NODE_TOL
        if np.any(off):
            raise ValueError(f"position x = {x[off][0]:g} m is not a deck node")
        return index

    def point_loads(self, positions: np.ndarray, forces: np.ndarray) -> Tensor:
        """`n_dof` vector of downward forces [N] at deck nodes at `positions` [m]."""
        F = torch.zeros(self.frame.n_dof, dtype=torch.float64)
        if len(positions):
            nodes = torch.as_tensor(self.deck_node(positions))
            F.index_add_(0, dof(nodes, 1), -torch.as_tensor(forces, dtype=torch.float64))
        return F

    def strain_operator(self, x: np.ndarray, c_b: np.ndarray | float) -> Tensor:
        """Operator `n x n_dof` giving the deck's bottom-fibre strain at positions `x` [m].

        A point on a node takes the mean of the two adjacent elements' end values (equal where
        the moment and the section are continuous).

        Args:
            x: `n` positions along the deck [m], within the deck.
            c_b: distance from the deck axis to the bottom fibre [mm], scalar or one value per
                deck element.
        """
        x = np.atleast_1d(np.asarray(x, dtype=np.float64))
        n_el = self.deck_x.size - 1
        c_b = np.broadcast_to(np.asarray(c_b, dtype=np.float64), (n_el,))
        right = np.clip(np.searchsorted(self.deck_x, x + NODE_TOL, side="right") - 1, 0, n_el - 1)
        on_node = np.abs(self.deck_x[right] - x) <= NODE_TOL
        left = np.where(on_node & (right > 0), right - 1, right)
        B = torch.zeros(x.size, self.frame.n_dof, dtype=torch.float64)
        for element in (left, right):
            xi = (x - self.deck_x[element]) / (self.deck_x[element + 1] - self.deck_x[element])
            B += 0.5 * bottom_strain_operator(
                self.frame,
                torch.as_tensor(element),
                torch.as_tensor(np.clip(xi, 0.0, 1.0)),
                torch.as_tensor(c_b[element]),
            )
        return B


def build_mesh(
    deck_x: np.ndarray,
    deck_EA: np.ndarray | float,
    deck_EI: np.ndarray | float,
    pier_x: np.ndarray,
    pier_height: float,
    pier_EA: np.ndarray | float,
    pier_EI: np.ndarray | float,
    pier_elements: int = 4,
    pier_base: PierBase = "hinged",
    K_r: float = 0.0,
) -> BridgeMesh:
    """Frame of a deck on end supports and piers.

    Args:
        deck_x: `n_deck` deck node positions [m], ascending, from 0 to the deck length,
            including the pier positions.
        deck_EA: axial stiffness [N], scalar or one value per deck element (`n_deck - 1`).
        deck_EI: bending stiffness [N·mm²], scalar or one value per deck element.
        pier_x: pier positions [m] (deck nodes).
        pier_height: pier length from the deck axis to the base [m].
        pier_EA: pier axial stiffness [N], scalar or one value per pier element (top first).
        pier_EI: pier bending stiffness [N·mm²], scalar or one value per pier element.
        pier_elements: elements per pier.
        pier_base: rotation condition at the pier bases.
        K_r: rotational spring at each pier base [N·mm/rad] (used when ``pier_base="spring"``).
    """
    deck_x = np.asarray(deck_x, dtype=np.float64)
    n_deck, n_el = deck_x.size, deck_x.size - 1
    depth = np.linspace(0.0, -pier_height * 1000.0, pier_elements + 1)[1:]
    pier_top = np.searchsorted(deck_x, np.asarray(pier_x) - NODE_TOL)
    nodes = [np.column_stack([deck_x * 1000.0, np.zeros(n_deck)])]
    elements = [np.column_stack([np.arange(n_el), np.arange(1, n_deck)])]
    bases = []
    for k, (x, top) in enumerate(zip(pier_x, pier_top)):
        first = n_deck + k * pier_elements
        nodes.append(np.column_stack([np.full(pier_elements, x * 1000.0), depth]))
        chain = np.concatenate([[top], np.arange(first, first + pier_elements)])
        elements.append(np.column_stack([chain[:-1], chain[1:]]))
        bases.append(first + pier_elements - 1)
    n_piers = len(pier_x)
    pier_EA = np.tile(np.broadcast_to(pier_EA, (pier_elements,)), n_piers)
    pier_EI = np.tile(np.broadcast_to(pier_EI, (pier_elements,)), n_piers)
    EA = np.concatenate([np.broadcast_to(deck_EA, (n_el,)), pier_EA])
    EI = np.concatenate([np.broadcast_to(deck_EI, (n_el,)), pier_EI])
    base = torch.as_tensor(bases, dtype=torch.int64)
    fixed = [dof(0, 0), dof(0, 1), dof(n_deck - 1, 1)]
    fixed_t = torch.cat([torch.tensor(fixed), dof(base, 0), dof(base, 1)])
    springs, stiffness = torch.zeros(0, dtype=torch.int64), torch.zeros(0, dtype=torch.float64)
    if pier_base == "fixed":
        fixed_t = torch.cat([fixed_t, dof(base, 2)])
    elif pier_base == "spring":
        springs, stiffness = dof(base, 2), torch.full((base.numel(),), float(K_r), dtype=torch.float64)
    elif pier_base != "hinged":
        raise ValueError(f"pier_base must be 'hinged', 'fixed' or 'spring', got {pier_base!r}")
    frame = Frame(
        nodes=torch.as_tensor(np.concatenate(nodes), dtype=torch.float64),
        elements=torch.as_tensor(np.concatenate(elements), dtype=torch.int64),
        EA=torch.as_tensor(EA, dtype=torch.float64),
        EI=torch.as_tensor(EI, dtype=torch.float64),
        fixed=torch.sort(fixed_t).values,
        spring_dofs=springs,
        spring_stiffness=stiffness,
    )
    return BridgeMesh(frame=frame, deck_x=deck_x, pier_base_rotations=dof(base, 2))

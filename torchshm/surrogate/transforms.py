"""Input and output transforms between a forward model and the surrogate's GP.

A linear elastic model whose stiffnesses all scale with one modulus E, except for springs of
stiffness K, gives strains ``ε(E, K) = g(K / E) / E`` exactly: the stiffness matrix is
``E (K_0 + (K / E) S)``. A model with that structure names its columns in its
``surrogate_transform`` attribute (keywords of :meth:`ResponseTransform.fit`), and then:

- GP inputs are ``log10 E`` and ``log10 K - log10 E`` (the log of the stiffness ratio), each
  scaled to the unit interval over the design, so that the response of a column of the design
  becomes a function of essentially one input;
- GP targets are ``E · ε`` (the strain at unit modulus), centred and divided by a scale for each
  output (or one scale for all), so that every output has a comparable size under one kernel.

The default (:data:`PLAIN`: ``modulus=None``, ``log_inputs=()``) is plain min-max input scaling
and output standardisation, suitable for any forward model.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import torch
from torch import Tensor

#: names of the output scalings
STANDARDIZE = ("output", "global")
#: transform keywords of :meth:`ResponseTransform.fit` for a model without known structure
PLAIN: dict[str, Any] = {"log_inputs": (), "modulus": None, "relative_to_modulus": ()}


def transform_of(model: object) -> dict[str, Any]:
    """Transform keywords suited to a forward model: its ``surrogate_transform`` attribute
    (bridge 705 and every fitted :class:`~torchshm.surrogate.Surrogate` have one), else
    :data:`PLAIN`."""
    own = getattr(model, "surrogate_transform", None)
    return dict(PLAIN if own is None else own)


@dataclass
class ResponseTransform:
    """Maps θp to unit-box GP inputs and strains to standardised GP targets, and back.

    Attributes:
        log_inputs: columns of θp replaced by their log10 (they must be positive).
        modulus: column of θp that is an elastic modulus (strains scale as its reciprocal),
            or None.
        relative_to_modulus: columns of θp that hold log10 of a stiffness that does not
            scale with the modulus; the GP sees ``θp[c] - log10 θp[modulus]``.
        lower: `P` smallest transformed input over the design.
        upper: `P` largest transformed input over the design.
        offset: `m` mean target over the design, in units of µε times the modulus.
        scale: `m` target scale, same units.
    """

    log_inputs: tuple[int, ...]
    modulus: int | None
    relative_to_modulus: tuple[int, ...]
    lower: Tensor
    upper: Tensor
    offset: Tensor
    scale: Tensor

    @classmethod
    def fit(
        cls, theta_p: Tensor, outputs: Tensor, *, log_inputs: tuple[int, ...] = (),
        modulus: int | None = None, relative_to_modulus: tuple[int, ...] = (),
        standardize: str = "output",
    ) -> ResponseTransform:
        """Fit the scalings to a design.

        Args:
            theta_p: `N x P` design [model units].
            outputs: `N x m` strains [µε] at the design, flattened over loads and sensors.
            log_inputs, modulus, relative_to_modulus: see the class attributes.
            standardize: "output" (a scale per output) or "global" (one scale for all).

        Raises:
            ValueError: on a column index out of range, a relative column without a modulus,
                an unknown ``standardize``, or a non-positive value in a log column.
        """
        n_par = theta_p.shape[-1]
        columns = (*log_inputs, *relative_to_modulus, *(() if modulus is None else (modulus,)))
        if any(not 0 <= c < n_par for c in columns):
            raise ValueError(f"transform column out of range for {n_par} parameters: {columns}")
        if relative_to_modulus and modulus is None:
            raise ValueError("relative_to_modulus needs a modulus column")
        if modulus is not None and modulus in relative_to_modulus:
            raise ValueError(f"column {modulus} cannot be relative to itself")
        if standardize not in STANDARDIZE:
            raise ValueError(f"standardize must be one of {STANDARDIZE}, got {standardize!r}")
        empty = torch.zeros(0, dtype=torch.float64)
        self = cls(tuple(log_inputs), modulus, tuple(relative_to_modulus), empty, empty,
                   empty, empty)
        raw = self.raw_inputs(theta_p)
        self.lower, self.upper = raw.min(dim=0).values, raw.max(dim=0).values
        targets = outputs / self.factor(theta_p)
        self.offset = targets.mean(dim=0)
        spread = targets.std(dim=0) if standardize == "output" else targets.std().expand(
            targets.shape[-1])
        floor = 1e-9 * float(spread.max()) if float(spread.max()) > 0 else 1.0
        self.scale = spread.clamp_min(floor).clone()
        return self

    def raw_inputs(self, theta_p: Tensor) -> Tensor:
        """Transformed inputs before unit-box scaling, `... x P`."""
        columns = list(theta_p.unbind(-1))
        for c in set(self.log_inputs) | ({self.modulus} - {None}):
            if bool((theta_p[..., c] <= 0).any()):
                raise ValueError(f"θp column {c} must be positive for its log10 transform")
        log_modulus = None if self.modulus is None else torch.log10(theta_p[..., self.modulus])
        for c in self.log_inputs:
            columns[c] = torch.log10(theta_p[..., c])
        for c in self.relative_to_modulus:
            columns[c] = theta_p[..., c] - log_modulus
        return torch.stack(columns, dim=-1)

    def inputs(self, theta_p: Tensor) -> Tensor:
        """GP inputs `... x P`: the design spans the unit box."""
        width = (self.upper - self.lower).clamp_min(1e-12)
        return (self.raw_inputs(theta_p) - self.lower) / width

    def factor(self, theta_p: Tensor) -> Tensor:
        """Strain per unit target, `... x 1`: ``1 / E`` with a modulus, else 1."""
        if self.modulus is None:
            return torch.ones_like(theta_p[..., :1])
        return 1.0 / theta_p[..., self.modulus : self.modulus + 1]

    def targets(self, theta_p: Tensor, outputs: Tensor) -> Tensor:
        """Standardised GP targets `N x m` of strains `N x m` [µε] at ``theta_p`` `N x P`."""
        return (outputs / self.factor(theta_p) - self.offset) / self.scale

    def strains(self, theta_p: Tensor, values: Tensor) -> Tensor:
        """Strains [µε] `... x m` from standardised GP values `... x m`."""
        return (self.offset + self.scale * values) * self.factor(theta_p)

    def strain_variance(self, theta_p: Tensor, variance: Tensor) -> Tensor:
        """Strain variance [µε²] `... x m` from the shared GP variance `... x 1`."""
        return variance * (self.scale * self.factor(theta_p)) ** 2

    def options(self) -> dict[str, Any]:
        """The structural keywords of :meth:`fit` this transform was fitted with."""
        return {"log_inputs": self.log_inputs, "modulus": self.modulus,
                "relative_to_modulus": self.relative_to_modulus}

    def state(self) -> dict[str, Any]:
        """Plain, ``weights_only``-loadable content for saving."""
        return {
            "log_inputs": list(self.log_inputs), "modulus": self.modulus,
            "relative_to_modulus": list(self.relative_to_modulus), "lower": self.lower,
            "upper": self.upper, "offset": self.offset, "scale": self.scale,
        }

    @classmethod
    def from_state(cls, state: dict[str, Any]) -> ResponseTransform:
        """Inverse of :meth:`state`."""
        return cls(
            tuple(state["log_inputs"]), state["modulus"], tuple(state["relative_to_modulus"]),
            state["lower"], state["upper"], state["offset"], state["scale"],
        )

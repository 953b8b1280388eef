"""The bridge 705 case study, built on the library (see ``docs/bridge705.md``).

Everything specific to the paper's structure lives here and nowhere else: the 2-D frame finite
element model (:mod:`.model`, :mod:`.frame`, :mod:`.geometry`, :mod:`.config`, :mod:`.truck`),
the truth structure behind the synthetic campaign (:mod:`.truth`) and the shipped campaign
(:mod:`.campaign`, ``bridge705_campaign.nc``), the shipped GP surrogate and its training grid
(:mod:`.surrogate`, ``bridge705_surrogate.pt``) and the paper's priors (:mod:`.priors`). The
generic packages (``data``, ``problem``, ``surrogate``, ``inference``, ...) never import it;
names are imported lazily, so that the frame model does not load the surrogate's GP code.
"""

from __future__ import annotations

from torchshm._lazy import lazy_dir, lazy_getattr

#: public name -> module of this package that defines it
_EXPORTS: dict[str, str] = {
    "Bridge705": "model",
    "bridge705": "model",
    "Bridge705Config": "config",
    "Rectangle": "config",
    "Frame": "frame",
    "T1": "truck",
    "T1_POSITIONS": "truck",
    "Truck": "truck",
    "TruthConfig": "truth",
    "truth_strains": "truth",
    "synthetic_campaign": "campaign",
    "paper_priors": "priors",
    "POSTERIOR_BOX": "surrogate",
    "PRIOR_BOX": "surrogate",
    "bridge705_surrogate": "surrogate",
    "paper_design": "surrogate",
    "shipped_path": "surrogate",
}

__all__ = sorted(_EXPORTS)


__getattr__ = lazy_getattr("torchshm.casestudy", _EXPORTS, globals(), prefix="torchshm.casestudy.")
__dir__ = lazy_dir(_EXPORTS, globals())

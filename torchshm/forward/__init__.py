"""Forward models: the protocol every model follows, and a wrapper for external programs.

A forward model maps physical parameters θp `... x P` to strains [µε] `... x L x n` for all
its load cases at once; see :class:`ForwardModel`. :class:`ExternalModel` runs a user's
finite element program once per θp through files (``params.json`` in, strains out).
"""

from __future__ import annotations

from torchshm.forward.external import ExternalModel, ExternalModelError
from torchshm.forward.files import read_params, read_strains, write_strains
from torchshm.forward.parallel import ParallelModel
from torchshm.forward.protocol import ForwardModel, as_tensor, model_identity, output_shape

__all__ = [
    "ExternalModel",
    "ExternalModelError",
    "ForwardModel",
    "ParallelModel",
    "as_tensor",
    "model_identity",
    "output_shape",
    "read_params",
    "read_strains",
    "write_strains",
]

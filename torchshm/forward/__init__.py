"""Forward models: the protocol every model follows, and a wrapper for external programs.

A forward model maps physical parameters θp `... x P` to strains [µε] `... x L x n` for all
its load cases at once; see :class:`ForwardModel`. :class:`ExternalModel` runs a user's
finite element program once per θp through files (``params.json`` in, strains out);
:class:`UMBridgeModel` calls a model served over UM-Bridge (HTTP).
"""

from __future__ import annotations

from torchshm.forward.cores import CoresPerRun
from torchshm.forward.external import ExternalModel, ExternalModelError
from torchshm.forward.files import read_params, read_strains, write_strains
from torchshm.forward.parallel import ParallelModel
from torchshm.forward.protocol import ForwardModel, as_tensor, model_identity, output_shape
from torchshm.forward.umbridge_model import UMBridgeError, UMBridgeModel

__all__ = [
    "CoresPerRun",
    "ExternalModel",
    "ExternalModelError",
    "ForwardModel",
    "ParallelModel",
    "UMBridgeError",
    "UMBridgeModel",
    "as_tensor",
    "model_identity",
    "output_shape",
    "read_params",
    "read_strains",
    "write_strains",
]

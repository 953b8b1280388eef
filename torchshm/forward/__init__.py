"""Forward models: the protocol every model follows, and a wrapper for external programs.

A forward model maps physical parameters θp `... x P` to strains [µε] `... x L x n` for all
its load cases at once; see :class:`ForwardModel`. :class:`ExternalModel` runs a user's
finite element program once per θp through files (``params.json`` in, strains out);
:class:`TemplateModel` fills a deck template, runs the program and reads its result file with a
reader such as :class:`CalculixStrain`;
:class:`UMBridgeModel` calls a model served over UM-Bridge (HTTP).
"""

from __future__ import annotations

from torchshm.forward.axes import load_axis
from torchshm.forward.calculix import CalculixStrain, read_frd
from torchshm.forward.cores import CoresPerRun
from torchshm.forward.external import ExternalModel, ExternalModelError
from torchshm.forward.files import read_params, read_strains, write_strains
from torchshm.forward.protocol import ForwardModel, as_tensor, model_identity, output_shape
from torchshm.forward.runs import KEEP_POLICIES, RunFolders
from torchshm.forward.template import TemplateModel, placeholders
from torchshm.forward.umbridge_model import UMBridgeError, UMBridgeModel

__all__ = [
    "KEEP_POLICIES",
    "CalculixStrain",
    "CoresPerRun",
    "ExternalModel",
    "ExternalModelError",
    "ForwardModel",
    "RunFolders",
    "TemplateModel",
    "UMBridgeError",
    "UMBridgeModel",
    "as_tensor",
    "load_axis",
    "model_identity",
    "output_shape",
    "placeholders",
    "read_frd",
    "read_params",
    "read_strains",
    "write_strains",
]

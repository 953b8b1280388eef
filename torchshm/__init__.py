"""torchshm: Bayesian system identification of structures from spatially dense strain data.

The public names below (see ``docs/api.md``: signatures and examples) are imported lazily, so that
``import torchshm`` stays fast and a command-line tool pays only for what it uses.
"""

from __future__ import annotations

import os

from torchshm._lazy import lazy_dir, lazy_getattr

# GPyTorch imports pykeops when it is installed (the benchmarks' peer), and pykeops prints a
# notice about CUDA libraries on a CPU machine at that import; torchshm uses no KeOps kernel.
# A user's own KEOPS_VERBOSE wins.
os.environ.setdefault("KEOPS_VERBOSE", "0")

__version__ = "0.1.0"

#: public name -> sub-package that defines it
_EXPORTS: dict[str, str] = {
    "bridge705": "torchshm.casestudy",
    "Bridge705": "torchshm.casestudy",
    "synthetic_campaign": "torchshm.casestudy",
    "Measurements": "torchshm.data",
    "load_measurements": "torchshm.data",
    "KERNELS": "torchshm.kernels",
    "get_kernel": "torchshm.kernels",
    "log_likelihood": "torchshm.likelihood",
    "Problem": "torchshm.problem",
    "Uniform": "torchshm.priors",
    "Gamma": "torchshm.priors",
    "Normal": "torchshm.priors",
    "paper_priors": "torchshm.casestudy",
    "fit_surrogate": "torchshm.surrogate",
    "load_surrogate": "torchshm.surrogate",
    "bridge705_surrogate": "torchshm.casestudy",
    "ExternalModel": "torchshm.forward",
    "TemplateModel": "torchshm.forward",
    "CalculixStrain": "torchshm.forward",
    "UMBridgeModel": "torchshm.forward",
    "ParallelModel": "torchshm.storage",
    "EvaluationStore": "torchshm.storage",
    "EvaluationResult": "torchshm.storage",
    "evaluate": "torchshm.storage",
    "make_executor": "torchshm.storage",
    "dask_client": "torchshm.storage",
    "identify": "torchshm.inference",
    "Posterior": "torchshm.inference",
    "load_posterior": "torchshm.inference",
    "posterior_predictive": "torchshm.predictive",
    "predictive_memory": "torchshm.predictive",
    "bayes_factors": "torchshm.predictive",
    "kl_divergence": "torchshm.predictive",
}

__all__ = sorted(_EXPORTS)


__getattr__ = lazy_getattr("torchshm", _EXPORTS, globals())
__dir__ = lazy_dir(_EXPORTS, globals())

"""The likelihood of Eq. (21): a batched block-diagonal Gaussian (pure mathematics).

The identification problem that uses it is :class:`torchshm.problem.Problem`.
"""

from __future__ import annotations

from torchshm.likelihood.gaussian import log_likelihood

__all__ = ["log_likelihood"]

"""Accuracy of a surrogate against the forward model it replaces, at held-out parameters.

The parameter box is the caller's (e.g. from the priors' plausible or hard bounds, or bridge
705's :data:`torchshm.casestudy.surrogate.PRIOR_BOX`).
"""

from __future__ import annotations

from dataclasses import dataclass
import torch
from torch import Tensor

from torchshm.arrays import as_float64
from torchshm.forward.protocol import ForwardModel
from torchshm.surrogate.surrogate import Surrogate

def uniform_in_box(n: int, box: tuple[tuple[float, float], ...], seed: int) -> Tensor:
    """`n x P` parameters drawn uniformly in ``box`` (one (low, high) per parameter)."""
    g = torch.Generator().manual_seed(seed)
    low, high = (torch.tensor(side, dtype=torch.float64) for side in zip(*box))
    return low + (high - low) * torch.rand(n, len(box), generator=g, dtype=torch.float64)


@dataclass(frozen=True)
class SurrogateErrors:
    """Errors of a surrogate at `R` held-out parameter vectors, over all `L x n` outputs.

    Attributes:
        max_abs: largest |surrogate − model| [µε].
        rms: root mean square of the error [µε].
        max_rel_run_peak: largest ratio of a run's max error to that run's peak |strain|.
        max_rel_peak: max_abs over the peak |strain| of all runs.
        peak: peak |strain| [µε] over all runs.
        max_sd_ratio: largest ratio of the error to the predicted standard deviation
            (over outputs with a positive variance), a check of the stated uncertainty.
        n_runs: number of held-out runs R.
    """

    max_abs: float
    rms: float
    max_rel_run_peak: float
    max_rel_peak: float
    peak: float
    max_sd_ratio: float
    n_runs: int

    def line(self) -> str:
        """One line of text with every figure."""
        return (f"{self.n_runs} runs: max |err| {self.max_abs:.3e} µε, rms {self.rms:.3e} µε, "
                f"max err / run peak {self.max_rel_run_peak:.2e}, max err / peak "
                f"{self.max_rel_peak:.2e} (peak {self.peak:.2f} µε), max |err| / sd "
                f"{self.max_sd_ratio:.2g}")


def surrogate_errors(surrogate: Surrogate, model: ForwardModel, theta_p: Tensor) -> SurrogateErrors:
    """Compare ``surrogate`` with ``model`` at `R x P` held-out parameters."""
    theta = as_float64(theta_p)
    with torch.no_grad():
        truth, (mean, var) = as_float64(model(theta)), surrogate.predict(theta)
    error = (mean - truth).abs()
    run_peak = truth.abs().amax(dim=(-2, -1))
    sd = var.sqrt()
    ratio = torch.where(sd > 0, error / sd.clamp_min(1e-300), torch.zeros_like(error))
    return SurrogateErrors(
        max_abs=float(error.max()), rms=float(error.square().mean().sqrt()),
        max_rel_run_peak=float((error.amax(dim=(-2, -1)) / run_peak).max()),
        max_rel_peak=float(error.max() / run_peak.max()), peak=float(run_peak.max()),
        max_sd_ratio=float(ratio.max()), n_runs=int(theta.shape[0]),
    )

"""The priors of the paper: Table 2 distributions with Table 4 hard and plausible bounds."""

from __future__ import annotations

from torchshm.priors.base import Prior
from torchshm.priors.distributions import Gamma, Uniform


def paper_priors() -> dict[str, Prior]:
    """Priors of the paper's Table 2, keyed by parameter name, physical parameters first.

    - ``E_c`` [GPa]: Uniform(10, 100), plausible (20, 60);
    - ``log10_K_r`` [log10 N·mm/rad]: Uniform(0, 12), plausible (1, 11);
    - ``sigma_a`` [µε]: Gamma(2, 2) (rate 2) truncated to (0, 5), plausible (0.2, 2.0);
    - ``length`` [m]: Gamma(3, 1) (rate 1) truncated to (0, 10), plausible (0.2, 5.0).

    Returns:
        A new dict (safe to modify) in the order above.
    """
    return {
        "E_c": Uniform(10.0, 100.0, plausible=(20.0, 60.0)),
        "log10_K_r": Uniform(0.0, 12.0, plausible=(1.0, 11.0)),
        "sigma_a": Gamma(2.0, 2.0, bounds=(0.0, 5.0), plausible=(0.2, 2.0)),
        "length": Gamma(3.0, 1.0, bounds=(0.0, 10.0), plausible=(0.2, 5.0)),
    }

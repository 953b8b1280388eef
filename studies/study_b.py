"""Study B (paper, Sec. 5, Table 7): the five discrepancy kernels, inferred on load 39.8 m.

    python studies/study_b.py [--n-jobs 2] [hydra overrides, e.g. method.max_fun_evals=100]

One ``torchshm-identify`` multirun over the kernels (joblib launcher, two jobs), predicting the
inferred load 39.8 m and the unobserved 47.5, 55.1, 62.8 and 70.4 m; then Tables 8, 9 and 10
and the Fig. 9 analog are written into the sweep folder (see ``studies/collect_study.py``).
"""

from __future__ import annotations

import sys

from collect_study import run_sweep  # beside this file

OVERRIDES = [
    "kernel=independent,exponential,matern32,matern52,squared_exponential",
    "data.loads=[39.8]",
    "predict.loads=[39.8,47.5,55.1,62.8,70.4]",
]

if __name__ == "__main__":
    run_sweep("b", OVERRIDES, sys.argv[1:])

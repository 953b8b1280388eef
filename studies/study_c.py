"""Study C (paper, Sec. 6, Table 11): six fibre resolutions, Matérn 3/2, all loads but 70.4 m.

    python studies/study_c.py [--n-jobs 2] [hydra overrides, e.g. method.max_fun_evals=100]

One ``torchshm-identify`` multirun over the resolutions 0.1, 0.2, 0.5, 1, 2 and 4 m (joblib
launcher, two jobs), inferring on the eleven load cases other than 70.4 m and predicting 70.4 m;
then Tables 12 and 13 and the Fig. 11 analog are written into the sweep folder (see
``studies/collect_study.py``).
"""

from __future__ import annotations

import sys

from collect_study import run_sweep  # beside this file

OVERRIDES = [
    "resolution=0.1,0.2,0.5,1,2,4",
    "kernel=matern32",
    "data.loads=[10.5,16.9,24.5,32.2,39.8,47.5,55.1,62.8,78.1,85.7,99.9]",
    "predict.loads=[70.4]",
]

if __name__ == "__main__":
    run_sweep("c", OVERRIDES, sys.argv[1:])

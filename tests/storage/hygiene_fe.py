"""A stand-in FE program for the process-hygiene tests (run as ``python hygiene_fe.py``).

Reads ``params.json``, appends its θp to the file ``$HYGIENE_CALLS``, and writes strains
``theta_0 * (1 + x)`` for every load case. A θp whose first value is at least 100 is *slow*: it
starts a child ``sleep`` in its process group, writes its own pid and the child's to
``slow-<pid>.pids`` in ``$HYGIENE_CALLS``'s folder, then sleeps ``$HYGIENE_SLOW_S`` seconds.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

params = json.loads(Path(os.environ["TORCHSHM_PARAMS"]).read_text())
theta, x, loads = params["theta_p"], np.array(params["x"]), np.array(params["loads"])
calls = Path(os.environ["HYGIENE_CALLS"])
with open(calls, "a") as handle:
    handle.write(f"{theta[0]!r}\n")
if theta[0] >= 100:
    child = subprocess.Popen(["sleep", "300"])
    (calls.parent / f"slow-{os.getpid()}.pids").write_text(f"{os.getpid()} {child.pid}\n")
    time.sleep(float(os.environ.get("HYGIENE_SLOW_S", "300")))
    child.kill()
np.savez(os.environ["TORCHSHM_OUTPUT"], strain=np.outer(np.ones(len(loads)), theta[0] * (1 + x)))
sys.exit(0)

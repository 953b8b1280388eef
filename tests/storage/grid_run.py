"""Evaluate (part of) a grid of GridModel through a store; run as a separate process.

Usage: grid_run.py STORE COUNTER DELAY N_E N_K FIRST STOP [GO_FILE]
Rows FIRST:STOP of ``grid(N_E, N_K)`` are evaluated; with GO_FILE, the process writes
``GO_FILE.ready.<pid>`` and waits for GO_FILE to exist before starting.
"""

from __future__ import annotations

import os
import sys
import time

from storage_models import GridModel, grid

from torchshm.storage import evaluate


def main(argv: list[str]) -> None:
    store, counter, delay, n_e, n_k, first, stop = argv[:7]
    if len(argv) > 7:
        go = argv[7]
        open(f"{go}.ready.{os.getpid()}", "w").close()
        given_up = time.monotonic() + 900.0  # the test died before its signal: leave
        while not os.path.exists(go):
            if time.monotonic() > given_up:
                sys.exit("no start signal after 900 s")
            time.sleep(0.01)
    theta = grid(int(n_e), int(n_k))[int(first) : int(stop)]
    result = evaluate(GridModel(delay=float(delay), counter=counter), theta, store=store)
    print(result.summary())


if __name__ == "__main__":
    main(sys.argv[1:])

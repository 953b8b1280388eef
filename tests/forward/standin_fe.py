"""Stand-in for an external finite element program, following torchshm's file contract.

Reads ``params.json`` from the current folder and writes the strains of
:func:`strain_field` to ``strains.npz`` (or the file named by ``--output``; ``.csv`` writes the
long format). Some values of ``E_c`` (the first parameter) trigger failures:

* E_c < 0: prints an error and exits with status 2;
* E_c == 999: starts a child process and hangs (for timeouts; the child's pid goes to
  ``child.pid``);
* E_c == 998: exits with status 0 without writing strains;
* E_c == 997: writes a garbled strain file;
* E_c == 996: writes strains with one sensor position missing.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
import time


def strain_field(theta: list[float], x: list[float], loads: list[float]) -> list[list[float]]:
    """Analytic strains [µε] `L x n`.

    ``1000 sin(x - load / 10) / E_c + log10_K_r x / (1 + load)``, x and load in m.
    """
    e_c, log_k = theta
    return [[1e3 * math.sin(xi - load / 10.0) / e_c + log_k * xi / (1.0 + load) for xi in x]
            for load in loads]


def _write(path: str, strain: list[list[float]], x: list[float], loads: list[float]) -> None:
    if path.endswith(".csv"):
        rows = [(load, xi, value) for load, row in zip(loads, strain) for xi, value in zip(x, row)]
        rows.reverse()  # any row order is allowed
        with open(path, "w") as handle:
            handle.write("load,x,strain\n")
            handle.writelines(f"{load!r},{xi!r},{value!r}\n" for load, xi, value in rows)
    else:
        import numpy as np

        np.savez(path, strain=np.array(strain), x=np.array(x), loads=np.array(loads))


def main(argv: list[str]) -> int:
    output = argv[argv.index("--output") + 1] if "--output" in argv else "strains.npz"
    with open("params.json") as handle:
        params = json.load(handle)
    theta, x, loads = params["theta_p"], params["x"], params["loads"]
    print(f"stand-in FE run for {dict(zip(params['names'], theta))}")
    e_c = theta[0]
    if e_c < 0:
        print(f"error: negative modulus E_c={e_c}", file=sys.stderr)
        return 2
    if e_c == 999:
        child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(120)"])
        with open("child.pid", "w") as handle:
            handle.write(str(child.pid))
        time.sleep(120)
    if e_c == 998:
        return 0
    if e_c == 997:
        with open(output, "wb") as handle:
            handle.write(b"PK\x03\x04 this is not a finished archive")
        return 0
    strain = strain_field(theta, x, loads)
    if e_c == 996:
        strain, x = [row[:-1] for row in strain], x[:-1]
    _write(output, strain, x, loads)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

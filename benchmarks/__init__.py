"""The identification benchmark suite: cases (:mod:`benchmarks.cases`), their cheap forward
models (:mod:`benchmarks.models`) and the reference posteriors (``benchmarks/references/``).

The suite sits on top of torchshm and imports it; torchshm never imports the suite.
"""

from benchmarks.cases import Case, case_hash, make_measurements, make_problem
from benchmarks.catalog import CASES

__all__ = ["CASES", "Case", "case_hash", "make_measurements", "make_problem"]

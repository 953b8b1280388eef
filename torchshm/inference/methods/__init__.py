"""The built-in inference methods, each registered by its own module (:mod:`..registry`):
``emulator`` (the default), ``vbmc`` (PyVBMC, the paper's method) and ``emcee``."""

from __future__ import annotations

from torchshm.inference.methods import emcee, emulator, vbmc  # noqa: F401  (each registers itself)

"""Command-line tools: the ``torchshm-identify`` Hydra application and its run steps.

With :mod:`torchshm.config`, the only code that sees a ``DictConfig``.
"""

from __future__ import annotations

from typing import Sequence


def main(argv: Sequence[str] | None = None) -> None:
    """Run ``torchshm-identify`` (see :mod:`torchshm.cli.identify`)."""
    from torchshm.cli.identify import main as _main

    _main(argv)


__all__ = ["main"]

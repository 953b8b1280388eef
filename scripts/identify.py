"""``python scripts/identify.py [overrides]``: the same application as ``torchshm-identify``."""

from __future__ import annotations

from torchshm.cli.identify import main

if __name__ == "__main__":
    main()

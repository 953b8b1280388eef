"""The studies are scripts outside the package (``studies/``); their modules import each other
by file name, so the folder goes on ``sys.path`` for these tests."""

from __future__ import annotations

import sys
from pathlib import Path

STUDIES = Path(__file__).resolve().parents[2] / "studies"
if str(STUDIES) not in sys.path:
    sys.path.insert(0, str(STUDIES))

"""Constants shared by the likelihood's forms."""

from __future__ import annotations

import math

#: ``log(2π)``, the Gaussian normaliser per reading
LOG_2PI = math.log(2.0 * math.pi)

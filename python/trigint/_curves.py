"""Statistics of sets of curves shared by the claims and the figures (NumPy only)."""

from __future__ import annotations

import numpy as np


def runaway_curves(dev: np.ndarray, factor: float = 100.0) -> list[int]:
    """Curves whose largest |deviation| exceeds `factor` times the median curve's largest."""
    peak = np.nanmax(np.abs(dev), axis=1)
    return [int(i) for i in np.flatnonzero(peak > factor * np.nanmedian(peak))]

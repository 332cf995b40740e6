"""The deviation vectors a Lyapunov run starts from when none are given, and how often it
re-orthonormalizes: shared by :func:`trigint.lyapunov` and the ensembles' chunks, so that a
trajectory's exponents are the same bits either way."""

from __future__ import annotations

import functools

import numpy as np

#: the seed of the default deviation vectors (see :func:`default_deviation`)
DEFAULT_DEVIATION_SEED = 20150

#: renormalize every this many steps unless told: growth over 16 steps stays far from overflow
#: for any exponent a stable step can show, and the QR costs little beside the steps
RENORMALIZE_EVERY = 16


def default_deviation(n: int, count: int) -> tuple[np.ndarray, np.ndarray]:
    """The deviation vectors used when none are given: `count` orthonormal vectors in ℝ²ⁿ
    (rows of (δq, δp)), the Q factor of a standard normal matrix drawn with
    ``numpy.random.default_rng(DEFAULT_DEVIATION_SEED)``: deterministic, and in general position
    (no chance alignment with an invariant subspace).

    >>> dq, dp = default_deviation(3, 2)
    >>> dq.shape, bool(np.allclose(np.hstack([dq, dp]) @ np.hstack([dq, dp]).T, np.eye(2)))
    ((2, 3), True)
    """
    dq, dp = _drawn(int(n), int(count))
    return dq.copy(), dp.copy()


@functools.lru_cache(maxsize=64)
def _drawn(n: int, count: int) -> tuple[np.ndarray, np.ndarray]:
    """The vectors of :func:`default_deviation`, drawn once per size: an ensemble asks for them
    in every chunk, and each QR wakes the linear-algebra library's threads."""
    rng = np.random.default_rng(DEFAULT_DEVIATION_SEED)
    q, _ = np.linalg.qr(rng.standard_normal((2 * n, count)))
    rows = q.T
    return np.ascontiguousarray(rows[:, :n]), np.ascontiguousarray(rows[:, n:])

"""Resonant step sizes: where h k·ω = 2πr, to mark on resonance scans (Figure 3)."""

from __future__ import annotations

from dataclasses import dataclass
from math import gcd

import numpy as np

from .. import _check
from ._lattice import half_ball
from .conditions import frequencies, too_many_for

TWO_PI = 2.0 * np.pi


@dataclass(frozen=True)
class ResonantStep:
    """hω_ref at which h k·ω = 2πr; `order` is ‖k‖₁.

    Attributes
    ----------
    h_omega : float
        hω_ref.
    k : tuple of int
        The integer vector k.
    r : int
        The multiple of 2π, ≥ 1.
    order : int
        ‖k‖₁.

    Examples
    --------
    >>> from trigint.resonance import resonant_step_sizes
    >>> step = resonant_step_sizes([50.0], (2.0, 2.2), order=6)[0]
    >>> step.k, step.r, step.label()
    ((3,), 1, '2π/3')
    """

    h_omega: float
    k: tuple[int, ...]
    r: int

    @property
    def order(self) -> int:
        """‖k‖₁."""
        return sum(map(abs, self.k))

    def label(self) -> str:
        """'2π·r/k' for one frequency, else 'k=(…), r'."""
        if len(self.k) == 1:
            return f"2π·{self.r}/{self.k[0]}" if self.r != 1 else f"2π/{self.k[0]}"
        return f"k={self.k}, r={self.r}"


#: the most integer vectors k that resonant_step_sizes enumerates (about a second of work)
MAX_VECTORS = 10**6
#: the most pairs (k, r) it may have to visit (a few seconds of work)
MAX_PAIRS = 10**6


def _half_ball_size(d: int, order: int) -> int:
    """Number of k ∈ ℤ^d with 0 < ‖k‖₁ ≤ order, one of each pair ±k."""
    from math import comb

    return sum(2**j * comb(d, j) * comb(order, j) for j in range(1, min(d, order) + 1)) // 2


def _largest_order(d: int) -> int:
    k = 1
    while _half_ball_size(d, k + 1) <= MAX_VECTORS:
        k += 1
    return k


def resonant_step_sizes(omega, h_omega_range, order: int, *, omega_ref: float | None = None) -> list[ResonantStep]:
    """Every hω_ref in `h_omega_range` with h k·ω = 2πr for some k, ‖k‖₁ ≤ order, r ≥ 1.

    The work grows with the number of vectors k (at most 10⁶) times the number of r per k
    (about the range's width times order/2π); requests of more than 10⁶ pairs (k, r), a few
    seconds of work, are refused with ValueError before anything is enumerated.

    Parameters
    ----------
    omega : array of float
        The frequencies.
    h_omega_range : (float, float)
        The interval of hω_ref to search, 0 ≤ low < high.
    order : int
        The largest ‖k‖₁.
    omega_ref : float, optional
        The frequency that measures h (default: the largest).

    Returns
    -------
    list of ResonantStep

    h is measured through hω_ref (default: the largest frequency, as in `scan()`), as on the axes of
    the paper's Figure 3; for one frequency these are the hω = 2πr/k. Each step size is listed
    once, with the k of smallest norm (and r, k coprime for one frequency). Sorted by hω_ref.

    Examples
    --------
    >>> from trigint.resonance import resonant_step_sizes
    >>> [s.label() for s in resonant_step_sizes([50.0], (2.0, 2.2), order=6)]
    ['2π/3']
    """
    w = frequencies(omega)
    bounds = _check.real_array(h_omega_range, "h_omega_range").reshape(-1)
    if bounds.size != 2 or not 0 <= bounds[0] < bounds[1]:
        raise ValueError(f"h_omega_range: need (low, high) with 0 <= low < high, got {h_omega_range!r}")
    lo, hi = float(bounds[0]), float(bounds[1])
    order = _check.integer(order, "order", low=1)
    vectors = _half_ball_size(w.size, int(order))
    if vectors > MAX_VECTORS:
        raise too_many_for(omega, ValueError(
            f"order: {order} with {w.size} frequencies means {vectors:.3g} integer vectors k; at most "
            f"{MAX_VECTORS:.0e} are enumerated (choose order <= {_largest_order(w.size)})"
        ))
    # The largest frequency, as scan() and the paper's figures use it.
    ref = float(np.max(w)) if omega_ref is None else _check.real(omega_ref, "omega_ref", positive=True)
    if not ref > 0:
        raise ValueError(f"omega_ref: must be > 0, got {ref}")
    # Each k has |k·ω| ≤ order·max ω, hence at most (hi − lo)·order·max ω/(2π ω_ref) + 1 values of r.
    def pairs(n: int) -> float:
        return _half_ball_size(w.size, n) * ((hi - lo) * n * float(np.max(w)) / (TWO_PI * ref) + 1)

    if pairs(int(order)) > MAX_PAIRS:
        low, high = 0, int(order)  # pairs(low) fits, pairs(high) does not
        while high - low > 1:
            mid = (low + high) // 2
            low, high = (mid, high) if pairs(mid) <= MAX_PAIRS else (low, mid)
        raise ValueError(
            f"order: {order} over h*omega_ref in [{lo:g}, {hi:g}] means up to {pairs(int(order)):.3g} pairs (k, r) "
            f"to visit; at most {MAX_PAIRS:.0e} are (a few seconds of work). Choose order <= {max(low, 1)} or a "
            "narrower h_omega_range"
        )
    found: dict[float, ResonantStep] = {}
    for k in half_ball(w.size, int(order)):
        dot = float(k @ w)
        if dot <= 0:
            continue  # h k·ω = 2πr, r ≥ 1, needs k·ω > 0 (−k gives the same h with −r)
        # hω_ref = 2πr ω_ref/(k·ω) in [lo, hi]
        r_lo = max(1, int(np.ceil(lo * dot / (TWO_PI * ref) - 1e-12)))
        r_hi = int(np.floor(hi * dot / (TWO_PI * ref) + 1e-12))
        for r in range(r_lo, r_hi + 1):
            if w.size == 1 and gcd(int(k[0]), r) != 1:
                continue
            x = TWO_PI * r * ref / dot
            key = round(x, 12)
            step = ResonantStep(x, tuple(int(v) for v in k), r)
            if key not in found or step.order < found[key].order:
                found[key] = step
    return sorted(found.values(), key=lambda s: s.h_omega)

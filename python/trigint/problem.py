"""The problem class q'' + Ω²q = −∇U(q) with per-coordinate frequencies (paper §2.1)."""

from __future__ import annotations

import numpy as np

from . import _check
from .potentials import Potential


class OscillatoryProblem:
    """q'' + Ω²q = g(q) = −∇U(q), Ω = diag(ω₁ … ωₙ), ωᵢ ≥ 0 (ωᵢ = 0: a slow coordinate).

    Coordinates are grouped in blocks: block 0 holds the slow coordinates and blocks
    1 … ℓ the coordinates of each distinct non-zero frequency, in order of first appearance
    (paper §2.1, q = (q₀, q₁, …, q_ℓ)). `blocks=` overrides the grouping.

    Parameters
    ----------
    omega : array of float, shape (n,)
        The frequency of each coordinate.
    potential : Potential
        U(q), acting on n coordinates.
    blocks : array of int, shape (n,), optional
        Block label of each coordinate: 0 for every slow coordinate (and only those),
        1 … ℓ for the oscillatory ones, each label used.

    Examples
    --------
    >>> import trigint as ti
    >>> prob = ti.OscillatoryProblem([0.0, 50.0, 50.0 * 2**0.5],
    ...                              ti.PolynomialPotential([0.01], [[0, 1, 1]]))
    >>> prob.block_frequencies
    array([50.        , 70.71067812])
    """

    def __init__(self, omega, potential: Potential, *, blocks=None):
        omega = _check.real_array(omega, "omega", ndim=None, finite=False, nonempty=False)
        if omega.ndim != 1 or omega.size == 0:
            raise ValueError(f"omega: expected a 1-d array of n >= 1 frequencies, got shape {omega.shape}")
        if not np.all(np.isfinite(omega)):
            bad = int(np.flatnonzero(~np.isfinite(omega))[0])
            raise ValueError(f"omega: frequencies must be finite; omega[{bad}] = {omega[bad]}")
        if np.any(omega > 1e150):
            bad = int(np.flatnonzero(omega > 1e150)[0])
            raise ValueError(f"omega: omega[{bad}] = {omega[bad]:g} is too large: the energies need omega**2, "
                             "which must stay finite; frequencies up to 1e150 are allowed")
        if np.any(omega < 0):
            bad = int(np.flatnonzero(omega < 0)[0])
            raise ValueError(f"omega: frequencies must be >= 0; omega[{bad}] = {omega[bad]}")
        if not isinstance(potential, Potential):
            raise TypeError(
                "potential: expected a trigint potential (FPUPotential, PolynomialPotential, "
                f"PythonPotential), got {type(potential).__name__}"
            )
        potential.check_dim(omega.size)
        self.omega = omega
        self.omega.setflags(write=False)
        self.potential = potential
        self.blocks = _check_blocks(blocks, omega) if blocks is not None else _group(omega)
        self.blocks.setflags(write=False)

    @property
    def dim(self) -> int:
        """Number of coordinates n."""
        return self.omega.size

    @property
    def n_blocks(self) -> int:
        """ℓ, the number of oscillatory blocks."""
        return int(self.blocks.max(initial=0))

    @property
    def block_frequencies(self) -> np.ndarray:
        """The frequency of each block 1 … ℓ (the first coordinate's, if a block mixes them)."""
        return np.array([self.omega[np.flatnonzero(self.blocks == j)[0]] for j in range(1, self.n_blocks + 1)])

    @property
    def epsilon(self) -> float:
        """ε = 1 / min_j ω_j over the non-zero frequencies (inf if there are none)."""
        fast = self.omega[self.omega > 0]
        return float(1.0 / fast.min()) if fast.size else float("inf")

    def __repr__(self) -> str:
        return (
            f"OscillatoryProblem(n={self.dim}, blocks={self.n_blocks}, "
            f"frequencies={np.round(self.block_frequencies, 6).tolist()}, potential={self.potential!r})"
        )


def _group(omega: np.ndarray) -> np.ndarray:
    blocks = np.zeros(omega.size, dtype=np.int64)
    distinct: list[float] = []
    for i, w in enumerate(omega):
        if w == 0.0:
            continue
        if w not in distinct:
            distinct.append(float(w))
        blocks[i] = distinct.index(w) + 1
    return blocks


def _check_blocks(blocks, omega: np.ndarray) -> np.ndarray:
    b = np.asarray(blocks)
    if b.shape != omega.shape or b.dtype.kind not in "iu":
        raise ValueError(f"blocks: expected {omega.size} integer labels, got {b.dtype} array of shape {b.shape}")
    b = b.astype(np.int64)
    if np.any((b == 0) != (omega == 0)):
        raise ValueError("blocks: label 0 is for the slow coordinates (omega == 0), and only for them")
    used = np.unique(b[b > 0])
    if used.size and not np.array_equal(used, np.arange(1, used.size + 1)):
        raise ValueError(f"blocks: oscillatory labels must be 1, 2, ..., l with none skipped, got {used.tolist()}")
    return b

"""Integer vectors k ∈ ℤ^ℓ: enumeration by 1-norm, and exact lattice bases (Hermite normal form)."""

from __future__ import annotations

from math import comb

import numpy as np

#: the most vectors an enumeration may produce
MAX_VECTORS = 5_000_000


def count_vectors(ell: int, radius: int) -> int:
    """Number of k ∈ ℤ^ℓ with ‖k‖₁ ≤ radius (0 included): Σᵢ 2ⁱ C(ℓ, i) C(radius, i)."""
    return sum(2**i * comb(ell, i) * comb(radius, i) for i in range(min(ell, radius) + 1))


def check_size(ell: int, radius: int, what: str = "N_max") -> None:
    n = count_vectors(ell, radius)
    if n > MAX_VECTORS:
        raise ValueError(
            f"{what}: enumerating every k with ||k||_1 <= {radius} in Z^{ell} means {n:,} vectors, "
            f"more than the limit of {MAX_VECTORS:,}; choose a smaller {what}"
        )


def half_ball(ell: int, radius: int) -> np.ndarray:
    """Every k ≠ 0 with ‖k‖₁ ≤ radius whose first non-zero entry is positive (one of each ±k),
    as an int64 array of shape (P, ℓ), sorted by ‖k‖₁."""
    check_size(ell, radius)
    points = np.zeros((1, 0), dtype=np.int64)
    for _ in range(ell):
        used = np.abs(points).sum(axis=1)
        blocks = []
        for v in range(-radius, radius + 1):
            keep = points[used + abs(v) <= radius]
            blocks.append(np.column_stack([keep, np.full(len(keep), v, dtype=np.int64)]))
        points = np.concatenate(blocks)
    nonzero = points != 0
    first = np.argmax(nonzero, axis=1)
    lead = points[np.arange(len(points)), first]
    points = points[nonzero.any(axis=1) & (lead > 0)]
    norms = np.abs(points).sum(axis=1)
    return points[np.argsort(norms, kind="stable")]


def hermite_basis(vectors) -> list[list[int]]:
    """An integer basis (rows in Hermite normal form) of the lattice spanned by `vectors`.

    Exact arithmetic on Python integers: row operations with the extended Euclidean algorithm.
    """
    rows = [[int(x) for x in v] for v in vectors]
    rows = [r for r in rows if any(r)]
    if not rows:
        return []
    ell = len(rows[0])
    basis: list[list[int]] = []
    col = 0
    while rows and col < ell:
        # Fold every row's entry in this column into one pivot row by Euclid.
        pivot = None
        rest = []
        for r in rows:
            if r[col] == 0:
                rest.append(r)
                continue
            if pivot is None:
                pivot = r
                continue
            a, b = pivot, r
            while b[col] != 0:
                q = a[col] // b[col]
                a, b = b, [x - q * y for x, y in zip(a, b, strict=True)]
            pivot = a
            if any(b):
                rest.append(b)
        if pivot is not None:
            if pivot[col] < 0:
                pivot = [-x for x in pivot]
            basis.append(pivot)
        rows = [r for r in rest if any(r)]
        col += 1
    # Reduce entries above each pivot into [0, pivot).
    for i, row in enumerate(basis):
        c = next(j for j, x in enumerate(row) if x)
        for k in range(i):
            q = basis[k][c] // row[c]
            if q:
                basis[k] = [x - q * y for x, y in zip(basis[k], row, strict=True)]
    return basis


def in_lattice(k, basis: list[list[int]]) -> bool:
    """Whether k is an integer combination of the rows of a Hermite basis."""
    k = [int(x) for x in k]
    for row in basis:
        c = next(j for j, x in enumerate(row) if x)
        if any(k[:c]):
            return False
        if k[c] % row[c]:
            return False
        q = k[c] // row[c]
        k = [x - q * y for x, y in zip(k, row, strict=True)]
    return not any(k)

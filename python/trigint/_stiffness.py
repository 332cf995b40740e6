"""A symmetric positive semi-definite stiffness matrix A as frequencies and a modal basis.

A = QΛQᵀ; the modal coordinates x = Qᵀq satisfy x'' + Λx = Qᵀg(Qx), the diagonal problem of
paper §2.1 with ω_j = √λ_j. Eigenvalues within a relative tolerance of 0 are slow (eigh
returns about 10⁻¹²·|A| instead of an exact 0, which would otherwise become a spurious
frequency), and eigenvalues within a relative tolerance of each other form one block of equal
frequency whose value is one double: the filters of the methods are then functions of hΩ that
are constant on each eigenspace, so nothing depends on the basis chosen inside a block.

A is diagonalized one connected component (of the graph of its non-zero entries) at a time, so
a reducible A (the FPU chain's independent stiff springs) gets a sparse basis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import _check

#: the largest A diagonalized densely (eigh of a 5000 × 5000 matrix takes seconds, and
#: the basis holds n² doubles: 200 MB)
DENSE_MAX = 5000

#: default relative tolerances: eigenvalues below SLOW_TOLERANCE·max|λ| are 0; eigenvalues
#: within EQUAL_TOLERANCE·λ of each other are one
SLOW_TOLERANCE = 1e-10
EQUAL_TOLERANCE = 1e-10


@dataclass(frozen=True)
class Frequencies:
    """The distinct frequencies of a problem and how they were found.

    Attributes
    ----------
    values : array of float
        ω_1 … ω_ℓ, one per oscillatory block.
    multiplicities : array of int
        The number of coordinates (eigenvectors) of each block.
    slow : int
        The number of slow coordinates (ω = 0).
    max_relative_change : float
        The largest |ω_j − √λ_i| / √λ_i made by putting the eigenvalues λ_i of block j at one
        value (0 for a diagonal Ω).
    largest_zeroed : float
        The largest |λ| set to 0 as slow (0 for a diagonal Ω).

    Examples
    --------
    >>> import trigint as ti
    >>> f = ti.problems.fpu(3, 50.0, coordinates="original").frequencies
    >>> f.slow, f.values.round(12).tolist(), f.multiplicities.tolist()
    (3, [50.0], [3])
    """

    values: np.ndarray
    multiplicities: np.ndarray
    slow: int
    max_relative_change: float = 0.0
    largest_zeroed: float = 0.0

    def listing(self, limit: int = 8) -> str:
        """'ω (xmultiplicity)' for each block; the first and last few of a long list.

        Parameters
        ----------
        limit : int
            The most blocks listed; a longer list shows its first ``limit − 2`` entries, a
            count of the rest, and the last entry.
        """
        items = [f"{w:.10g} (x{k})" for w, k in zip(self.values, self.multiplicities, strict=True)]
        if len(items) > limit:
            items = [*items[:limit - 2], f"... {len(items) - limit + 1} more ...", items[-1]]
        return ", ".join(items)

    def __repr__(self) -> str:
        return (f"Frequencies(slow={self.slow}, [{self.listing()}], max_relative_change="
                f"{self.max_relative_change:.2e}, largest_zeroed={self.largest_zeroed:.2e})")


@dataclass(frozen=True)
class ModalBasis:
    """A = Q diag(ω²) Qᵀ with the columns of Q ordered slow first, then by block."""

    omega: np.ndarray
    blocks: np.ndarray
    basis: np.ndarray
    frequencies: Frequencies


def check_tolerance(value, name: str) -> float:
    tol = _check.real(value, name)
    if not 0.0 <= tol < 1.0:
        raise ValueError(f"{name}: a relative tolerance from 0 to below 1 is expected, got {tol!r}")
    return tol


def dense_stiffness(stiffness) -> np.ndarray:
    """A as a symmetric dense array, with every way it can be unfit named."""
    if is_sparse(stiffness):
        n = stiffness.shape[0]
        if stiffness.shape[0] != stiffness.shape[1]:
            raise ValueError(f"stiffness: A must be square, got shape {stiffness.shape}")
        if n > DENSE_MAX:
            raise ValueError(
                f"stiffness: a sparse A of size {n} x {n} is too large to diagonalize densely (at most "
                f"{DENSE_MAX}: the basis alone would need {8 * n * n / 2**30:.3g} GiB); give a smaller "
                "problem, or path='krylov' (matrix functions by the Lanczos method)"
            )
        stiffness = stiffness.toarray()
    if np.iscomplexobj(stiffness):
        raise TypeError("stiffness: complex entries are not allowed; A must be real symmetric")
    a = _check.real_array(stiffness, "stiffness", ndim=None, finite=False)
    if a.ndim != 2 or a.shape[0] != a.shape[1] or a.shape[0] == 0:
        raise ValueError(f"stiffness: A must be a square matrix of size n >= 1, got shape {a.shape}")
    if a.shape[0] > DENSE_MAX:
        raise ValueError(f"stiffness: A of size {a.shape[0]} is too large to diagonalize densely (at most "
                         f"{DENSE_MAX}); give it as a scipy.sparse matrix with path='krylov'")
    if not np.all(np.isfinite(a)):
        i, j = np.argwhere(~np.isfinite(a))[0]
        raise ValueError(f"stiffness: entries must be finite; A[{i}, {j}] = {a[i, j]}")
    scale = float(np.max(np.abs(a)))
    if scale > 1e250:
        raise ValueError(f"stiffness: entries up to 1e250 in size are allowed (ω² = λ must stay finite), "
                         f"got {scale:g}")
    asym = float(np.max(np.abs(a - a.T)))
    if asym > 1e-12 * scale:
        i, j = np.unravel_index(int(np.argmax(np.abs(a - a.T))), a.shape)
        raise ValueError(f"stiffness: A must be symmetric; |A - A^T| is {asym:.3g} (relative "
                         f"{asym / scale:.3g} > 1e-12), largest at A[{i}, {j}] = {float(a[i, j])!r} vs "
                         f"A[{j}, {i}] = {float(a[j, i])!r}")
    return 0.5 * (a + a.T)


def diagonalize(a: np.ndarray, slow_tolerance: float, equal_tolerance: float,
                preferred: np.ndarray | None = None) -> ModalBasis:
    """Frequencies and basis of a symmetric A (see the module's docstring). `preferred`, an
    orthogonal T that diagonalizes A to rounding (TᵀAT diagonal within 1e-13 of |A|), is
    taken as the basis itself (columns kept in their order within the slow and each block)."""
    n = a.shape[0]
    lam, q = _eigh_by_component(a)
    if preferred is not None and preferred.shape == a.shape:
        d = preferred.T @ a @ preferred
        off = d - np.diag(np.diag(d))
        size = max(float(np.max(np.abs(a))), 1e-300)
        if np.max(np.abs(off)) <= 1e-13 * size and np.allclose(preferred.T @ preferred, np.eye(n), atol=1e-14):
            # T's columns with LAPACK's eigenvalues (diag(TᵀAT) is an ulp off through T's rounding)
            rayleigh = np.diag(d)
            matched = np.empty(n)
            matched[np.argsort(rayleigh, kind="stable")] = np.sort(lam)
            lam, q = matched, np.array(preferred, dtype=float)
    if not np.all(np.isfinite(lam)):
        raise ValueError("stiffness: the eigenvalues of A overflow a double; scale the problem (entries up to "
                         "1e250 are allowed)")
    scale = float(np.max(np.abs(lam))) if lam.size else 0.0
    floor = slow_tolerance * scale
    negative = np.flatnonzero(lam < -floor)
    if negative.size:
        k = int(negative[np.argmin(lam[negative])])
        raise ValueError(
            f"stiffness: A must be positive semi-definite; it has the eigenvalue {lam[k]:.6g} (relative "
            f"{lam[k] / scale:.3g} to the largest |eigenvalue| {scale:.6g}, beyond slow_tolerance = "
            f"{slow_tolerance:g})"
        )
    slow = np.abs(lam) <= floor
    order = np.argsort(np.where(slow, -np.inf, lam), kind="stable")
    lam, q, slow = lam[order], q[:, order], slow[order]
    n_slow = int(np.count_nonzero(slow))
    blocks = np.zeros(n, dtype=np.int64)
    omega = np.zeros(n)
    values, counts, change = [], [], 0.0
    start = n_slow
    while start < n:
        end = start + 1
        while end < n and lam[end] - lam[start] <= equal_tolerance * lam[end]:
            end += 1
        w = float(np.sqrt(np.mean(lam[start:end])))
        omega[start:end] = w
        blocks[start:end] = len(values) + 1
        change = max(change, float(np.max(np.abs(w - np.sqrt(lam[start:end])) / np.sqrt(lam[start:end]))))
        values.append(w)
        counts.append(end - start)
        start = end
    zeroed = float(np.max(np.abs(lam[:n_slow]))) if n_slow else 0.0
    freqs = Frequencies(np.array(values), np.array(counts, dtype=np.int64), n_slow, change, zeroed)
    for arr in (omega, blocks, q):
        arr.setflags(write=False)
    return ModalBasis(omega, blocks, np.ascontiguousarray(q), freqs)


def _eigh_by_component(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """eigh of each connected component of A's graph: a block-diagonal A gets a sparse Q."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components

    n = a.shape[0]
    count, label = connected_components(csr_matrix(a != 0), directed=False)
    lam = np.empty(n)
    q = np.zeros((n, n))
    col = 0
    for c in range(count):
        idx = np.flatnonzero(label == c)
        w, v = np.linalg.eigh(a[np.ix_(idx, idx)])
        lam[col:col + idx.size] = w
        q[idx, col:col + idx.size] = v
        col += idx.size
    return lam, q


def sparse_stiffness(stiffness):
    """A as a symmetric CSR matrix for the Krylov path (never densified)."""
    from scipy.sparse import csr_matrix

    if not is_sparse(stiffness):
        a = dense_stiffness(stiffness) if np.ndim(stiffness) == 2 and np.shape(stiffness)[0] <= DENSE_MAX else None
        if a is None:
            raise TypeError("stiffness: the Krylov path takes a scipy.sparse matrix (or a dense array of size "
                            f"up to {DENSE_MAX})")
        return csr_matrix(a)
    if np.iscomplexobj(stiffness.data if hasattr(stiffness, "data") else stiffness):
        raise TypeError("stiffness: complex entries are not allowed; A must be real symmetric")
    a = csr_matrix(stiffness, dtype=float)
    if a.ndim != 2 or a.shape[0] != a.shape[1] or a.shape[0] == 0:
        raise ValueError(f"stiffness: A must be a square matrix, got shape {a.shape}")
    if not np.all(np.isfinite(a.data)):
        raise ValueError("stiffness: entries must be finite; A has a non-finite entry")
    scale = float(np.max(np.abs(a.data))) if a.nnz else 0.0
    if scale > 1e250:
        raise ValueError(f"stiffness: entries up to 1e250 in size are allowed, got {scale:g}")
    diff = a - a.T
    asym = float(np.max(np.abs(diff.data))) if diff.nnz else 0.0
    if asym > 1e-12 * scale:
        raise ValueError(f"stiffness: A must be symmetric; |A - A^T| is {asym:.3g} (relative {asym / scale:.3g} "
                         "> 1e-12)")
    if np.any(a.diagonal() < -1e-10 * scale):
        i = int(np.argmin(a.diagonal()))
        raise ValueError(f"stiffness: A must be positive semi-definite; its diagonal entry A[{i}, {i}] = "
                         f"{a.diagonal()[i]:g} is negative")
    out = ((a + a.T) * 0.5).tocsr()
    out.sort_indices()
    return out


def is_sparse(x) -> bool:
    try:
        from scipy.sparse import issparse
    except ImportError:  # pragma: no cover - scipy is a dependency
        return False
    return bool(issparse(x))

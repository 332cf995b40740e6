"""The FPU chain's linear forms: its spring elongations, its tape and its original coordinates
(Hairer, Lubich, Wanner, Geometric Numerical Integration, §I.5)."""

from __future__ import annotations

import numpy as np


def fpu_original_basis(m: int) -> np.ndarray:
    """T with q = T x: the original coordinates q₁ … q₂ₘ of the diagonal ones x (T orthogonal).

    Parameters
    ----------
    m : int
        The number of stiff springs (2m particles, 2m coordinates).

    Returns
    -------
    array of shape (2m, 2m)
    """
    t = np.zeros((2 * m, 2 * m))
    r = np.sqrt(0.5)
    for i in range(m):
        t[2 * i, i], t[2 * i, m + i] = r, -r          # q₂ᵢ₋₁ = (x₀,ᵢ − x₁,ᵢ)/√2
        t[2 * i + 1, i], t[2 * i + 1, m + i] = r, r   # q₂ᵢ = (x₀,ᵢ + x₁,ᵢ)/√2
    return t


def fpu_linear_forms(m: int) -> list[list[tuple[int, float]]]:
    """The FPU's spring elongations as sparse rows over x = (x₀,₁ … x₀,ₘ, x₁,₁ … x₁,ₘ)."""
    rows = [[(0, 1.0), (m, -1.0)]]
    for i in range(1, m):
        rows.append([(i, 1.0), (m + i, -1.0), (i - 1, -1.0), (m + i - 1, -1.0)])
    rows.append([(m - 1, 1.0), (2 * m - 1, 1.0)])
    return rows


def fpu_tape(m: int) -> dict:
    """¼ Σ y_k⁴ over the FPU's linear forms, as a tape (no expansion)."""
    ops: list[tuple] = [("input", i) for i in range(2 * m)]
    quarter = len(ops)
    ops.append(("const", 0.25))
    total = None
    for row in fpu_linear_forms(m):
        (i0, _), *rest = row
        acc = i0
        for j, c in rest:
            ops.append(("add" if c > 0 else "sub", acc, j))
            acc = len(ops) - 1
        ops.append(("powi", acc, 4))
        ops.append(("mul", quarter, len(ops) - 1))
        term = len(ops) - 1
        if total is None:
            total = term
        else:
            ops.append(("add", total, term))
            total = len(ops) - 1
    return {"n": 2 * m, "ops": ops, "output": total}

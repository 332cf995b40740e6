"""
A stiffness matrix: the chain in the particles' own coordinates
===============================================================

The Toda chain of the previous example, written as a physicist states it: 2m particles at
positions q₁ … q₂ₘ, stiff linear springs inside each pair (2i − 1, 2i) and soft Toda springs
V(y) = exp(−y) − 1 + y between the pairs and to the walls. The stiff springs give the
stiffness matrix A of q'' + Aq = −∇U(q), with 2 × 2 blocks (ω²/2)[[1, −1], [−1, 1]]: nobody has
to find the coordinates in which it is diagonal. trigint diagonalizes A once, groups its
eigenvalues (m slow ones and one frequency ω of multiplicity m), steps the modal coordinates and
hands everything back in q.

Left: the oscillatory energy H_ω (½(‖P p‖² + ω²‖P q‖²) with the spectral projector P of the
frequency ω) stays within O(ε) of its start. Right: the frequencies of a different chain, every
neighbour joined by a stiff spring and the ends fixed (A = ω² tridiag(−1, 2, −1)), whose n
distinct frequencies 2ω sin(kπ/(2(n + 1))) fill [0, 2ω]: trigint finds them from A the same way.
"""

import matplotlib.pyplot as plt
import numpy as np

import trigint as ti

m, omega = 20, 50.0
n = 2 * m
A = np.zeros((n, n))
for i in range(m):                       # stiff spring inside the pair (q₂ᵢ₋₁, q₂ᵢ)
    A[2 * i:2 * i + 2, 2 * i:2 * i + 2] = omega**2 / 2 * np.array([[1.0, -1.0], [-1.0, 1.0]])
L = np.zeros((m + 1, n))                 # soft springs: q₁ − wall, q₂ᵢ₊₁ − q₂ᵢ, wall − q₂ₘ
L[0, 0] = 1.0
for i in range(1, m):
    L[i, 2 * i], L[i, 2 * i - 1] = 1.0, -1.0
L[m, n - 1] = -1.0
U = ti.ChainPotential(n).add("exp(-y) - 1 + y", "y", matrix=L)
prob = ti.OscillatoryProblem(stiffness=A, potential=U)
print(prob.frequencies)

rng = np.random.default_rng(1)
q0 = np.repeat(rng.normal(0, 0.5, m), 2) / np.sqrt(2)    # pairs at rest relative to each other
p0 = np.repeat(rng.normal(0, 0.5, m), 2) / np.sqrt(2)
p0[0:2] += [-1.0, 1.0]                                   # H_ω = 1 in the first stiff spring
sol = ti.integrate(prob, "B", q0, p0, h=1.0 / omega, t_end=1000.0, save_every=25)
print(sol)

wall = ti.OscillatoryProblem(
    stiffness=omega**2 * (2 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1)),
    potential=ti.ChainPotential(n).add("exp(-y) - 1 + y", "y", pairs=[(i, i + 1) for i in range(n - 1)]))
exact = 2 * omega * np.sin(np.arange(1, n + 1) * np.pi / (2 * (n + 1)))
print("largest error of the found frequencies:", np.max(np.abs(wall.frequencies.values - exact) / exact))

fig, (ax, bx) = plt.subplots(1, 2, figsize=(10, 4))
ax.plot(sol.t, sol.deviation("oscillatory"), lw=0.8, label="H_ω")
ax.plot(sol.t, sol.deviation("total"), lw=0.8, label="H")
ax.set_xlabel("t")
ax.set_ylabel("E(t) − E(0)")
ax.set_title(f"pairs joined by stiff springs, ω = {omega:g}", fontsize=9)
ax.legend()
bx.vlines(wall.frequencies.values, 0, 1, lw=1, label="found from A")
bx.plot(exact, np.full(n, 1.05), "v", ms=4, label="2ω sin(kπ/(2(n + 1)))")
bx.set_ylim(0, 1.3)
bx.set_xlabel("frequency")
bx.set_yticks([])
bx.legend(fontsize=8, loc="upper left")
bx.set_title(f"A = ω² tridiag(−1, 2, −1): {n} distinct frequencies", fontsize=9)
fig.tight_layout()
plt.show()

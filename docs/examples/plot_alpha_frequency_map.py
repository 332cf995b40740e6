"""
The α-family's frequency map hω ↦ hω̃
=====================================

The symplectic α-methods (paper (2.6)) are modified trigonometric integrators (2.5) with
sin(½hω̃) = ½hω/√(1 + αh²ω²). Their modified frequency ω̃ is what the non-resonance conditions
see (Theorem 3.2): the IMEX method (α = ¼) maps hω = √12 to hω̃ = 2π/3, a resonance, and
Störmer–Verlet (α = 0) is only defined for hω < 2.
"""

import matplotlib.pyplot as plt
import numpy as np

import trigint as ti

x = np.linspace(0.0, 6.0, 601)
fig, ax = plt.subplots(figsize=(7, 4.5))
for alpha in [0.0, 0.1, 0.25, 0.5, 1.0]:
    method = ti.AlphaMethod(alpha)
    ok = x < method.h_omega_limit
    ax.plot(x[ok], method.modified_h_omega(x[ok]), label=f"α = {alpha:g}")
ax.plot(x, x, "k:", lw=0.8, label="hω̃ = hω (trigonometric methods)")
for r, text in [(2 * np.pi / 3, "2π/3"), (np.pi / 2, "π/2")]:
    ax.axhline(r, color="grey", lw=0.5, ls="--")
    ax.text(0.05, r, text, va="bottom", fontsize=8)
print("IMEX: hω = √12 ↦ hω̃ =", float(ti.IMEX().modified_h_omega(np.sqrt(12))), "= 2π/3 =", 2 * np.pi / 3)
ax.set_xlabel("hω")
ax.set_ylabel("hω̃")
ax.set_ylim(0, np.pi)
ax.legend(fontsize=8)
fig.tight_layout()
plt.show()

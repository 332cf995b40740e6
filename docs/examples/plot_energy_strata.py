"""
Energy strata, and a step size that breaks them
===============================================

u_tt = u_xx − ½u + u² on 32 points from u(x, 0) = 10⁻³ cos x: the energy of mode k stays of
size ε^(2k) (mode 0: ε⁴), the metastable strata of Gauckler, Hairer, Lubich and Weiss (2012).
At h = 0.05 the method keeps them; at h = 0.965, where ½h(ω_4 + 4ω_1) is near π,
:func:`trigint.resonance.strata_resonances` predicts that mode 4 leaves its stratum, and it does.
"""

import matplotlib.pyplot as plt
import numpy as np

import trigint as ti

prob = ti.problems.wave(32, rho=0.5, potential="-u**3/3")  # V(u) = -u³/3: the equation's +u²
(x,) = prob.grid
eps = 1e-3
e0 = np.zeros(len(prob.modes))
e0[1] = 0.375 * eps**2  # E_1 of ε cos x: ½ ω_1² ε²/2
for h in (0.05, 0.965):
    found = ti.resonance.strata_resonances(prob, h, e0)
    print(f"h = {h}: " + (f"mode {found[0].affected[0]} predicted to rise {found[0].weight:.3g}x in energy" if found
                          else "no combination near a resonance"))

fig, axes = plt.subplots(1, 2, figsize=(9, 3.6), sharey=True)
for ax, h in zip(axes, (0.05, 0.965), strict=True):
    n = int(600 / h)
    sol = ti.integrate(prob, "B", eps * np.cos(x), 0 * x, h=h, n_steps=n, save_every=max(1, n // 600))
    E = sol.energies["action"] * sol.energies.omega  # E_k = ω_k J_k
    for k in range(6):
        ax.semilogy(E.t, E.isel(mode=k), lw=0.8, label=f"k = {k}")
    ax.set_title(f"h = {h}")
    ax.set_xlabel("t")
axes[0].set_ylabel("mode energy E_k(t)")
axes[0].legend(fontsize=7, ncol=2, frameon=False)
fig.tight_layout()
plt.show()

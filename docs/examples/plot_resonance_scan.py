"""
A resonance scan with the theory's resonant step sizes
======================================================

The maximum deviation of H_ω over 0 ≤ t ≤ 2000 as a function of hω, for method B on the FPU
problem (the paper's Figure 3, on a shorter interval). Dashed lines mark the step sizes with
h k ω = 2π r, ‖k‖ ≤ 6, listed by :func:`trigint.resonance.resonant_step_sizes`: the peaks sit
in the near-resonance band of width √h next to them, where (3.6) fails.
"""

import matplotlib.pyplot as plt
import numpy as np

import trigint as ti
from trigint.resonance import resonant_step_sizes

prob = ti.problems.fpu(m=3, omega=50.0)
q0, p0 = ti.problems.fpu_initial(m=3, omega=50.0)

h_omega = np.linspace(1.5, 2.4, 361)
scan = ti.scan(prob, "B", q0, p0, h_omega=h_omega, t_end=2000.0, progress=False)

fig, ax = plt.subplots(figsize=(8, 4))
ax.semilogy(scan.h_omega, scan, lw=0.8)
for step in resonant_step_sizes(prob.omega, (h_omega[0], h_omega[-1]), order=6):
    ax.axvline(step.h_omega, ls="--", color="grey", lw=0.7)
    ax.text(step.h_omega, float(scan.max()), step.label(), fontsize=8, ha="center", va="bottom")
    print(f"resonance hω = {step.label()} = {step.h_omega:.5f}")
ax.set_xlabel("hω")
ax.set_ylabel("max |H_ω(t) − H_ω(0)|")
fig.tight_layout()
plt.show()

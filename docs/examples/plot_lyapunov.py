"""
Lyapunov exponents of the integrator's own map
==============================================

Left: the leading finite-time Lyapunov exponent of the FPU problem (m = 3, ω = 50, the paper's
initial data) integrated by method B to t = 300, against hω, with the multiples of π dashed.
The slow motion of the chain is chaotic at every step size: the finite-time exponent scatters
between about 0.07 and 0.16 (a chaotic orbit's exponent at t = 300) with no systematic change at
hω = π. It measures the problem, not the step size. Right: a 1-D wave equation
u_tt = u_xx − u − u³ on 128 points, weak and strong initial data: MEGNO ⟨Y⟩ stays near 0 for
the weak one (a nearly linear, isochronous motion: deviations stay bounded; a regular motion
with shear gives 2) and grows like λt/2 for the strong, chaotic one.
"""

import matplotlib.pyplot as plt
import numpy as np

import trigint as ti

prob = ti.problems.fpu(m=3, omega=50.0)
q0, p0 = ti.problems.fpu_initial(m=3, omega=50.0)
h_omega = np.linspace(0.4, 3.6, 161)
scan = ti.scan(prob, "B", q0, p0, h_omega=h_omega, t_end=300.0, lyapunov=1, progress=False)

wave = ti.problems.wave((128,), rho=1.0, potential="u**4/4")
(x,) = wave.mesh
runs = {}
for amplitude in (0.1, 3.0):
    u0 = amplitude * (np.cos(x) + 0.5 * np.sin(3 * x))
    runs[amplitude] = ti.lyapunov(wave, "B", u0, np.zeros_like(u0), h=0.05, t_end=400.0)
    print(f"wave, amplitude {amplitude}: {runs[amplitude]}")

fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4))
left.plot(scan.h_omega, scan.lyapunov, ".-", lw=0.7, ms=3)
for k in range(1, int(h_omega[-1] / np.pi) + 1):
    left.axvline(k * np.pi, ls="--", color="grey", lw=0.7)
left.set_xlabel("hω")
left.set_ylabel("leading exponent λ₁ at t = 300")
left.set_title("FPU, method B")
for amplitude, res in runs.items():
    right.plot(res.megno.t, res.megno, label=f"amplitude {amplitude}")
right.axhline(2, color="grey", lw=0.6, ls="--")
right.set_xlabel("t")
right.set_ylabel("MEGNO <Y>")
right.set_title("1-D wave equation, method B, h = 0.05")
right.legend()
fig.tight_layout()
plt.show()

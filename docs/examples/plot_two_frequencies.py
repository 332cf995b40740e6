"""
Two frequencies and the non-resonance report
============================================

The paper's Experiment 3: frequencies ω and √2 ω, U = 0.01 q₁q₂, step h = 2π/(ω₁ + ω₂), so that
h(ω₁ + ω₂) = 2π is an exact numerical resonance. :func:`trigint.resonance.analyze` says which
condition fails and what the theorems still guarantee; the energies show it: method A (whose
filter ψ vanishes at the resonance) keeps H_ω, method B lets it grow linearly (Figure 5).
"""

import matplotlib.pyplot as plt

import trigint as ti
from trigint.resonance import analyze

omega = 100.0
prob = ti.problems.experiment3(omega)
q0, p0 = ti.problems.experiment3_initial(omega)
h = ti.problems.experiment3_step(omega)

print(analyze(h, prob.omega, method="B", N_max=4))

fig, ax = plt.subplots(figsize=(8, 4))
for name in "AB":
    sol = ti.integrate(prob, name, q0, p0, h=h, t_end=500.0, save_every=50)
    ax.plot(sol.t, sol.deviation("oscillatory"), label=f"method {name}")
ax.set_xlabel("t")
ax.set_ylabel("H_ω(t) − H_ω(0)")
ax.legend()
fig.tight_layout()
plt.show()

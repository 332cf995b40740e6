"""The kernels' copies per instruction set (AVX-512, AVX2, baseline x86-64; `TRIGINT_ISA` caps
the choice) give the same bits: one trajectory, an ensemble on the lane loop, a compiled
expression (alone and in the lane loop), the Krylov path, and the tangent steps (lyapunov() alone and in bundles)."""

import os
import subprocess
import sys

import numpy as np
import pytest

SCRIPT = r"""
import sys, numpy as np, scipy.sparse, sympy as sp, trigint as ti
prob = ti.problems.fpu(3, 50.0); q0, p0 = ti.problems.fpu_initial(3, 50.0)
h = 2 * np.pi / 3 / 50
one = ti.integrate(prob, "B", q0, p0, h=h, n_steps=3000, save_every=1000)
# a filter phi != 1 and the modified energy of a modified method, in the one-trajectory loop
one_e = ti.integrate(prob, "E", q0, p0, h=h, n_steps=3000, save_every=1000)
modified = ti.ModifiedTrigonometric(lambda x: 2 * np.arctan(x / 2), chi="mclachlan-stern")
one_m = ti.integrate(prob, modified, q0, p0, h=h, n_steps=3000, save_every=1000)
Q0, P0 = ti.perturb(q0, p0, np.linspace(0, 1e-6, 16))
ens = ti.ensemble(prob, "C", Q0, P0, h=h * (1 + np.linspace(0, 1e-3, 16)), n_steps=2000, save_every=1000, threads=1)
x = sp.symbols("x0:6")
expr = ti.OscillatoryProblem(prob.omega, ti.ExpressionPotential(sum(sp.cos(v) * v**2 for v in x), x))
ex = ti.integrate(expr, "B", q0, p0, h=h, n_steps=2000, save_every=1000)
# the lane loop with the expression's machine code called on the bundle's rows
ex_ens = ti.ensemble(expr, "B", Q0[:9], P0[:9], h=h, n_steps=2000, save_every=1000, threads=1)
n = 300
a = scipy.sparse.diags([-np.ones(n - 1), 2 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1]).tocsr() * 100.0
sites = ti.ChainPotential(n).add("y**4/4", "y", sites=range(n))
chain = ti.OscillatoryProblem(stiffness=a, potential=sites, path="krylov")
kr = ti.integrate(chain, "D", np.sin(np.linspace(0, 3, n)), np.zeros(n), h=0.05, n_steps=30, save_every=30)
# a chain on the recursion (its own copies of the stepping loop): one trajectory and lanes
springs = ti.OscillatoryProblem(np.full(40, 50.0), ti.ChainPotential(40).add("y**4/4 + y**3/3", "y", sites=range(40)))
y0 = 0.02 * np.cos(np.arange(40)); Y0, V0 = ti.perturb(y0, np.zeros(40), np.linspace(0, 1e-6, 9))
ch = ti.integrate(springs, "C", y0, np.zeros(40), h=h, n_steps=2000, save_every=1000)
ch_ens = ti.ensemble(springs, "B", Y0, V0, h=h, n_steps=1000, save_every=500, threads=1)
# the tangent steps: one trajectory (two vectors, a filter), a compiled expression, bundled lanes
ly = ti.lyapunov(prob, "C", q0, p0, h=h, n_steps=3000, n_exponents=2)
ly_ex = ti.lyapunov(expr, "B", q0, p0, h=h, n_steps=2000)
ly_ens = ti.ensemble(prob, "B", Q0[:9], P0[:9], h=h, n_steps=2000, lyapunov=1, threads=1)
np.savez(sys.argv[1], ly=ly.exponents, ly_megno=ly.megno.values, ly_hist=ly.history.values,
         ly_ex=ly_ex.exponents, ly_ens=ly_ens.lyapunov.values, ly_ens_megno=ly_ens.megno.values,
         one=one.q, one_dev=np.array(list(one.max_deviation.values())), ens=ens.q.values,
         one_e=one_e.q, one_e_dev=np.array(list(one_e.max_deviation.values())),
         one_m_dev=np.array(list(one_m.max_deviation.values())),
         ens_dev=ens.max_deviation.values, ex=ex.q, ex_ens=ex_ens.q.values,
         ex_ens_dev=ex_ens.max_deviation.values, kr=kr.q, ch=ch.q,
         ch_dev=np.array(list(ch.max_deviation.values())), ch_ens=ch_ens.q.values)
"""


def run_with(isa: str | None, path) -> dict:
    env = {k: v for k, v in os.environ.items() if k != "TRIGINT_ISA"}
    if isa is not None:
        env["TRIGINT_ISA"] = isa
    subprocess.run([sys.executable, "-c", SCRIPT, str(path)], check=True, env=env, timeout=300)
    with np.load(path) as f:
        return {k: f[k] for k in f.files}


@pytest.mark.parametrize("isa", ["avx2", "baseline"])
def test_every_instruction_set_copy_gives_the_same_bits(tmp_path, isa):
    best = run_with(None, tmp_path / "best.npz")
    capped = run_with(isa, tmp_path / f"{isa}.npz")
    for key, value in best.items():
        np.testing.assert_array_equal(capped[key], value, err_msg=key)
    assert np.max(np.abs(best["one"][-1] - best["one"][0])) > 0.1

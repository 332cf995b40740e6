"""The forms of one method agree: one-step vs two-step, (2.5) vs (2.6), IMEX."""

import warnings

import numpy as np
import pytest

import trigint as ti
from trigint import _reference as ref

H = 1.5 / 50.0  # hω = 1.5: inside every method's stability interval


def test_one_step_and_two_step_agree(method, fpu):
    prob, q0, p0 = fpu
    a = ti.integrate(prob, method, q0, p0, h=H, n_steps=1000, form="two-step")
    b = ti.integrate(prob, method, q0, p0, h=H, n_steps=1000, form="one-step")
    assert np.max(np.abs(a.q - b.q)) < 1e-10
    assert np.max(np.abs(a.p - b.p)) < 1e-10


@pytest.mark.parametrize("alpha", [0.0, 0.1, 0.25, 0.4, 1.0])
def test_alpha_family_equals_direct_recursion(alpha, fpu):
    prob, q0, p0 = fpu
    sol = ti.integrate(prob, ti.AlphaMethod(alpha), q0, p0, h=H, n_steps=1000)
    q, p = ref.alpha_direct(ref.fpu_gradient, H, prob.omega, alpha, q0, p0, 1000)
    assert np.max(np.abs(sol.q - q)) < 1e-12
    assert np.max(np.abs(sol.p - p)) < 1e-12


# With hω = 6 (h = 0.12) the slow FPU motion amplifies rounding differences faster, so that
# case runs over a shorter time.
@pytest.mark.parametrize(("h_omega", "n"), [(1.0, 1000), (2.0, 1000), (np.sqrt(12.0), 1000), (6.0, 200)])
def test_imex_matches_its_one_step_form(h_omega, n, fpu):
    prob, q0, p0 = fpu
    h = h_omega / 50.0
    sol = ti.integrate(prob, ti.IMEX(), q0, p0, h=h, n_steps=n)
    q, p = ref.imex_one_step(ref.fpu_gradient, h, prob.omega, q0, p0, n)
    assert np.max(np.abs(sol.q - q)) < 1e-10
    assert np.max(np.abs(sol.p - p)) < 1e-10


def test_imex_modified_energy_is_weighted_oscillatory_energy(fpu):
    """Paper §3.2: for α = ¼, H*_ω̃ = Σ_j (ω̃_j/ω_j) I_j."""
    prob, q0, p0 = fpu
    h = np.sqrt(12.0) / 50.0
    imex = ti.IMEX()
    co = imex.coefficients(h, prob.omega)
    fast = prob.omega > 0
    ratio = co.xi_tilde[fast] / co.xi[fast]
    assert np.allclose(co.modified_p[fast], ratio, rtol=1e-14)
    assert np.allclose(co.modified_q[fast], ratio * prob.omega[fast] ** 2, rtol=1e-14)
    assert np.allclose(co.xi_tilde[fast], 2 * np.pi / 3, rtol=1e-14)
    sol = ti.integrate(prob, imex, q0, p0, h=h, n_steps=500, save_every=50)
    expected = ratio[0] * sol.energies["oscillatory"]
    assert np.allclose(sol.energies["modified_oscillatory"], expected, rtol=1e-13)
    e = ti.energies(prob, sol.q, sol.p, imex, h)
    assert np.allclose(e["modified_oscillatory"], expected, rtol=1e-13)


def test_symplectic_trigonometric_modified_energy_is_oscillatory(fpu):
    prob, q0, p0 = fpu
    sol = ti.integrate(prob, "C", q0, p0, h=0.04, n_steps=300, save_every=10)
    assert np.allclose(sol.energies["modified_oscillatory"], sol.energies["oscillatory"], rtol=1e-14)
    sol = ti.integrate(prob, "A", q0, p0, h=0.04, n_steps=300, save_every=10)
    sigma = ti.Trigonometric("A").sigma(0.04, prob.omega)[-1]
    assert sigma != pytest.approx(1.0, abs=1e-3)
    assert np.allclose(sol.energies["modified_oscillatory"], sigma * sol.energies["oscillatory"], rtol=1e-13)


@pytest.mark.parametrize("name", ["B", "C", "E"])
@pytest.mark.parametrize("k", [1, 2])
def test_one_step_form_is_defined_at_multiples_of_pi(name, k):
    """At hω = kπ, χ = sinc vanishes: the two-step form's momentum is undefined, but the one-step
    form of B, C and E needs only ψ/χ (φ, sinc, sinc) and sin²/(hχ) = ω sin(hω). Its trajectory
    there is the limit of those at hω = kπ(1 ± δ): the midpoint of the two neighbours, to second
    order in δ, while the neighbours themselves differ to first order."""
    import warnings

    prob = ti.problems.fpu()
    q0, p0 = ti.problems.fpu_initial()
    h = k * np.pi / 50
    with pytest.raises(ValueError, match=r"or use form='one-step' in integrate\(\), ensemble\(\) or scan\(\)"):
        ti.integrate(prob, name, q0, p0, h=h, n_steps=10)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        at, up, down = (ti.integrate(prob, name, q0, p0, h=h * (1 + d), n_steps=200, form="one-step", save_every=1)
                        for d in (0.0, 1e-7, -1e-7))
    assert at.status == "completed"
    spread = np.abs(up.p - down.p).max()
    assert spread > 1e-5
    assert np.abs(at.q - (up.q + down.q) / 2).max() < 1e-3 * spread
    assert np.abs(at.p - (up.p + down.p) / 2).max() < 1e-3 * spread
    modified = at.energies["modified_oscillatory"].values
    if name == "E":  # σ = 1/sinc has no limit: H*_ω is undefined and reported as NaN
        assert np.all(np.isnan(modified))
        with pytest.warns(RuntimeWarning) as caught:
            ti.integrate(prob, name, q0, p0, h=h, n_steps=10, form="one-step")
        messages = [str(w.message) for w in caught]
        assert any("modified oscillatory energy is undefined" in m for m in messages)
        assert any(f"numerical resonance: h*omega[3] = {h * 50:.10g}" in m for m in messages)  # κ = 0
    else:  # σ = 1: H*_ω = H_ω
        np.testing.assert_array_equal(modified, at.energies["oscillatory"].values)


@pytest.mark.parametrize("name", ["A", "D"])
def test_one_step_form_refuses_what_is_undefined(name):
    """A and D have ψ = sinc²(ξ/2), which does not vanish at odd multiples of π: ψ/χ is undefined."""
    prob = ti.problems.fpu()
    q0, p0 = ti.problems.fpu_initial()
    with pytest.raises(ValueError, match=f"one-step form of method '{name}' needs psi/chi there, which is undefined"):
        ti.integrate(prob, name, q0, p0, h=np.pi / 50, n_steps=10, form="one-step")


def test_ensemble_in_the_one_step_form_is_integrate_in_it_bit_for_bit(fpu):
    """ensemble(form='one-step'): each trajectory, in bundles of lanes and alone, with the bits of
    integrate(form='one-step'), at kπ too; lyapunov= keeps the two-step form; a store remembers
    the form it was made with."""
    prob, q0, p0 = fpu
    hs = np.array([0.02, np.pi / 50, 0.03, 0.021, 0.019, 0.022, 0.018, 0.025, 0.0205])  # hω = π at index 1
    Q0 = np.array([q0 * (1 + 1e-3 * k) for k in range(hs.size)])
    ds = ti.ensemble(prob, "C", Q0, p0, h=hs, n_steps=400, save_every=100, form="one-step", threads=1)
    for k in (0, 1, 8):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # hω = π: the resonance warning
            alone = ti.integrate(prob, "C", Q0[k], p0, h=float(hs[k]), n_steps=400, save_every=100, form="one-step")
        assert np.array_equal(ds.q.values[k], alone.q) and np.array_equal(ds.p.values[k], alone.p)
        assert ds.max_deviation.values[k, 0] == alone.max_deviation["total"]
    with pytest.raises(ValueError, match="form: must be one of"):
        ti.ensemble(prob, "C", Q0, p0, h=hs, n_steps=10, form="onestep")
    with pytest.raises(ValueError, match="form: lyapunov=… takes the tangent map of the two-step form"):
        ti.ensemble(prob, "C", Q0, p0, h=hs, n_steps=10, form="one-step", lyapunov=1)


def test_a_store_is_not_resumed_in_the_other_form(fpu, tmp_path):
    prob, q0, p0 = fpu
    hs = np.array([0.02, 0.03])
    ti.ensemble(prob, "C", q0, p0, h=hs, n_steps=50, store=tmp_path / "s", form="one-step")
    with pytest.raises(ValueError, match="store"):
        ti.ensemble(prob, "C", q0, p0, h=hs, n_steps=50, store=tmp_path / "s")

"""Problems of random arrangements (slow coordinates, blocks of 1 to 4 coordinates in any order,
one of 472 coordinates, so that the observing sweep cuts several passes): what a run streams is
what NumPy computes from its samples, where the samples are taken changes no bit, and an
ensemble's lane is the run alone. (A pass of blocks of 1 and 3 coordinates was once taken for
two blocks of two.)"""

import numpy as np
import pytest
from test_state_energies import numpy_energies

import trigint as ti

METHODS = ["A", "B", "C", "D", "E", "imex"]


def random_problem(rng):
    blocks = int(rng.integers(2, 260 if rng.random() < 0.3 else 10))
    sizes = rng.choice([1, 2, 3, 4, 2, 2, 1, 3], size=blocks)
    slow = int(rng.integers(0, 3))
    omega = np.concatenate([np.zeros(slow)] + [np.full(s, f) for s, f in zip(sizes, rng.uniform(5, 60, blocks),
                                                                             strict=True)])
    if rng.random() < 0.3:
        omega = omega[rng.permutation(omega.size)]
    n = omega.size
    coefficients, exponents = [], []
    for _ in range(int(rng.integers(1, 6))):  # couplings of up to three coordinates
        e = np.zeros(n, int)
        idx = rng.choice(n, size=min(n, int(rng.integers(1, 4))), replace=False)
        e[idx] = rng.integers(1, 4, size=idx.size)
        exponents.append(e.tolist())
        coefficients.append(float(rng.uniform(-1, 1)))
    for i in range(min(n, 3)):
        e = np.zeros(n, int)
        e[i] = 4
        exponents.append(e.tolist())
        coefficients.append(0.5)
    return ti.OscillatoryProblem(omega, ti.PolynomialPotential(coefficients, exponents)), n


@pytest.mark.parametrize("seed", range(12))
def test_random_arrangements_stream_what_their_samples_give(seed):
    rng = np.random.default_rng(seed)
    prob, n = random_problem(rng)
    method = METHODS[seed % len(METHODS)]
    q0, p0 = 0.05 * rng.normal(size=n), 0.5 * rng.normal(size=n)
    h, steps = float(rng.uniform(0.002, 0.05)), int(rng.integers(5, 40))
    sol = ti.integrate(prob, method, q0, p0, h=h, n_steps=steps, save_every=1)
    want = numpy_energies(prob, np.asarray(sol.q), np.asarray(sol.p))
    for name, w in want.items():
        scale = np.abs(w).max()
        np.testing.assert_allclose(sol.energies[name].values, w, rtol=0, atol=1e-12 * scale, err_msg=name)
        assert sol.max_deviation[name] == pytest.approx(np.abs(w - w[0]).max(), abs=1e-11 * scale), name
    sparse = ti.integrate(prob, method, q0, p0, h=h, n_steps=steps, save_every=7)
    assert np.array_equal(sparse.q[-1], sol.q[-1]) and np.array_equal(sparse.p[-1], sol.p[-1])
    assert all(sparse.max_deviation[k] == sol.max_deviation[k] for k in sol.max_deviation)
    lanes = ti.ensemble(prob, method, q0, p0, h=[h, 0.7 * h], n_steps=steps, save_every=None)
    assert np.array_equal(lanes.max_deviation.values[0], [sol.max_deviation[k] for k in lanes.energy.values])

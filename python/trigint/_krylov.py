"""Matrix functions of h√A applied by the Lanczos method, for large sparse stiffness matrices.

For A of size n ≥ 10⁴ the eigenvectors cannot be stored (n² doubles). Each product f(h√A) v
is instead taken from the Krylov space span{v, Av, …, A^{k−1}v}: with the Lanczos basis V_k
and tridiagonal T_k = V_kᵀ A V_k,

    f(h√A) v ≈ |v| V_k f(h√T_k) e₁,

several f at once from one basis [Saad 1992; Hochbruck–Lubich 1997]. The filters of every
method are even functions of hω, hence analytic functions of λ = ω², so the error falls
geometrically in k once k exceeds about h√λ_max. The iteration stops when the a posteriori
estimate β_k |e_kᵀ f(h√T_k) e₁| of every f is below `tol` times |f(h√T_k)e₁| twice in a row
(at most MAX_ITERATIONS steps). No reorthogonalization: for analytic f the Lanczos
approximation converges without it [Druskin–Greenbaum–Knizhnerman 1998]; the estimate catches
the delay.

The iteration, the sparse products and the steps of the one-step form run in the core
(``trigint-core``'s ``krylov`` module), one trajectory or an ensemble on all cores. The named
trigonometric methods A–E have their functions in closed form there; every other method is
evaluated by its own coefficient code (:class:`MatrixFunctions`) at the Ritz values, a handful
of numbers per Lanczos step.
"""

from __future__ import annotations

import numpy as np

from . import _core, _native

#: the most Lanczos steps for one product
MAX_ITERATIONS = 400


class MatrixFunctions:
    """θ ↦ the one-step form's numbers at ω = √θ, as rows in the order of
    ``_core.KRYLOV_FUNCTIONS`` (the method's own coefficient code; picklable with the method).

    Parameters
    ----------
    method : Method
        Any method.
    h : float
        The step size.
    """

    def __init__(self, method, h: float):
        self.method, self.h = method, float(h)

    def __call__(self, theta: np.ndarray) -> np.ndarray:
        co = self.method.coefficients(self.h, np.sqrt(np.maximum(theta, 0.0)), form="one-step")
        rows = {"one_minus_cos": co.one_minus_cos, "chi": co.chi, "psi": co.psi, "phi": co.phi,
                "psi_over_chi": co.psi_over_chi, "sin2_over_h_chi": co.sin2_over_h_chi,
                "c_psi_over_chi": (1.0 - co.one_minus_cos) * co.psi_over_chi}
        return np.array([rows[name] for name in _native.KRYLOV_FUNCTIONS], dtype=float)

    def phi_is_identity(self) -> bool:
        """Whether φ = 1 at a few points hω ∈ {0, ½, 1, 2, 3} (then the force is taken at q), those
        a method with a stability limit on hω (the α-family with α < ¼: Störmer–Verlet's 2) allows."""
        h_omega = np.array([0.0, 0.5, 1.0, 2.0, 3.0])
        limit = getattr(self.method, "h_omega_limit", np.inf)
        h_omega = np.append(h_omega[h_omega < limit], 0.9 * limit) if np.isfinite(limit) else h_omega
        probe = self((h_omega / self.h) ** 2)
        return bool(np.all(probe[_native.KRYLOV_FUNCTIONS.index("phi")] == 1.0))


def method_spec(method, h: float) -> dict:
    """One trajectory's method as the core takes it: a named trigonometric filter (closed forms in
    the core) or the method's own functions (:class:`MatrixFunctions`)."""
    letter = getattr(method, "named_filter", None)
    if letter in _native.KRYLOV_FILTERS:
        return {"h": float(h), "filter": letter}
    functions = MatrixFunctions(method, h)
    return {"h": float(h), "functions": functions, "phi_is_identity": functions.phi_is_identity()}


def stiffness_spec(problem) -> dict:
    """The CSR arrays of A and the stopping rule, as the core takes them."""
    a = problem.stiffness
    return {"path": "krylov", "n": int(a.shape[0]), "indptr": np.ascontiguousarray(a.indptr, dtype=np.int64),
            "indices": np.ascontiguousarray(a.indices, dtype=np.int64),
            "data": np.ascontiguousarray(a.data, dtype=float), "tol": float(problem.krylov_tolerance)}


def energies(problem, q: np.ndarray, p: np.ndarray) -> np.ndarray:
    """The channels (``channel_names(1)``) of each row of q, p (B × n), by the core's formula, the
    one its runs stream: ½|p|² + ½qᵀAq is H_ω when A has no zero eigenvalue (the slow part ½|P₀p|²
    is not separated on this path), H_slow = U(q), NaN for the modified energy."""
    spec = stiffness_spec(problem)
    potential = _native.built_potential(problem.potential, problem.dim)
    return _core.krylov_energies(potential, spec["n"], spec["indptr"], spec["indices"], spec["data"],
                                 np.ascontiguousarray(np.atleast_2d(q), dtype=float),
                                 np.ascontiguousarray(np.atleast_2d(p), dtype=float))


def run(potential_core, spec: dict, method, h, q0: np.ndarray, p0: np.ndarray, n_steps, save_every,
        track: bool, threads=None, callback=None):
    """Runs the rows of q0, p0 (B × n), trajectory t with step size h[t], on the Krylov path in the
    core; returns the core's RunResult, its `info` holding the Lanczos counts (per trajectory,
    and for one trajectory also the totals :attr:`Solution.info` shows)."""
    h = np.atleast_1d(np.asarray(h, dtype=float))
    methods = [method_spec(method, ht) for ht in h]
    out = _native.integrate_krylov(potential_core, spec, methods, MAX_ITERATIONS, np.atleast_2d(q0),
                                   np.atleast_2d(p0), [int(s) for s in np.atleast_1d(n_steps)], save_every,
                                   track, threads, callback)
    if len(h) == 1:
        iterations, products = out.info["iterations"][0], out.info["products"][0]
        out.info.update(iterations=iterations, products=products,
                        iterations_per_product=iterations / max(products, 1))
    return out


def integrate(problem, method, q0, p0, h: float, n_steps: int, save_every: int, track: bool, callback):
    """Runs one trajectory on the Krylov path; returns the core's RunResult, from which
    :func:`trigint.integrate` builds its Solution (states in the user's coordinates, which are
    the only ones here)."""
    potential = _native.built_potential(problem.potential, problem.dim)
    return run(potential, stiffness_spec(problem), method, h, q0, p0, n_steps, save_every, track,
               callback=callback)

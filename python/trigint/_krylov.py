"""Matrix functions of h√A applied by the Lanczos method, for large sparse stiffness matrices.

For A of size n ≥ 10⁴ the eigenvectors cannot be stored (n² doubles). Each product f(h√A) v
is instead taken from the Krylov space span{v, Av, …, A^{k−1}v}: with the Lanczos basis V_k
and tridiagonal T_k = V_kᵀ A V_k,

    f(h√A) v ≈ |v| V_k f(h√T_k) e₁,

several f at once from one basis [Saad 1992; Hochbruck–Lubich 1997]. The filters of every
method are even functions of hω, hence analytic functions of λ = ω², so the error falls
geometrically in k once k exceeds about h√λ_max. The iteration stops when the a posteriori
estimate β_k |e_kᵀ f(h√T_k) e₁| of every f is below `tol` times |f(h√T_k)e₁| (at most
MAX_ITERATIONS steps). No reorthogonalization: for analytic f the Lanczos approximation
converges without it [Druskin–Greenbaum–Knizhnerman 1998]; the estimate catches the delay.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.linalg import eigh_tridiagonal

from . import _native

#: the most Lanczos steps for one product
MAX_ITERATIONS = 400


class KrylovFailure(RuntimeError):
    """A product did not reach its tolerance within MAX_ITERATIONS steps."""


def apply_functions(a, v: np.ndarray, functions: Callable[[np.ndarray], dict], names: tuple[str, ...],
                    tol: float) -> tuple[dict, int]:
    """{name: f_name(A) v} for the functions `functions(θ)[name]` of eigenvalues θ of A, and
    the number of Lanczos steps taken."""
    beta0 = float(np.linalg.norm(v))
    if beta0 == 0.0 or not np.isfinite(beta0):
        return {k: np.zeros_like(v) if beta0 == 0.0 else np.full_like(v, np.nan) for k in names}, 0
    basis = np.empty((16, v.size))  # grows by doubling; rows are the Lanczos vectors
    basis[0] = v / beta0
    alpha: list[float] = []
    beta: list[float] = []
    previous = False
    w = np.empty_like(v)
    for k in range(MAX_ITERATIONS):
        w[:] = a @ basis[k]
        if k > 0:
            w -= beta[k - 1] * basis[k - 1]
        alpha.append(float(basis[k] @ w))
        w -= alpha[k] * basis[k]
        b = float(np.linalg.norm(w))
        theta, s = eigh_tridiagonal(np.array(alpha), np.array(beta)) if k else (np.array(alpha), np.ones((1, 1)))
        values = functions(np.maximum(theta, 0.0))
        coeffs = np.array([s @ (values[name] * s[0]) for name in names])
        invariant = b <= 1e-13 * max(abs(alpha[k]), 1.0)
        scale = np.maximum(np.linalg.norm(coeffs, axis=1), 1e-300)
        converged = bool(np.all(b * np.abs(coeffs[:, -1]) <= tol * scale))
        # two agreeing estimates in a row guard against an early lucky small entry
        if invariant or (converged and previous):
            products = beta0 * (coeffs @ basis[:k + 1])
            return dict(zip(names, products, strict=True)), k + 1
        previous = converged
        beta.append(b)
        if k + 1 == basis.shape[0]:
            basis = np.concatenate([basis, np.empty_like(basis)])
        np.divide(w, b, out=basis[k + 1])
    raise KrylovFailure(f"the Lanczos method did not reach the tolerance {tol:g} in {MAX_ITERATIONS} steps "
                        "(h·sqrt(largest eigenvalue) too large for this tolerance; take a smaller h or a "
                        "larger tol)")


def _filter_functions(method, h: float):
    """θ ↦ the one-step form's numbers at ω = √θ (the method's own coefficient code)."""

    def functions(theta: np.ndarray) -> dict:
        co = method.coefficients(h, np.sqrt(theta), form="one-step")
        return {
            "one_minus_cos": co.one_minus_cos, "chi": co.chi, "psi": co.psi, "phi": co.phi,
            "psi_over_chi": co.psi_over_chi, "sin2_over_h_chi": co.sin2_over_h_chi,
            "c_psi_over_chi": (1.0 - co.one_minus_cos) * co.psi_over_chi,
        }

    return functions


class KrylovStepper:
    """The one-step (velocity) form of any method, GNI XIII (2.7)–(2.9), with every matrix
    function of h√A applied by :func:`apply_functions`:

        q_{n+1} = q_n − (1 − c)q_n + hχ p_n + ½h²ψ g_n,
        p_{n+1} = p_n − (1 − c)p_n − (s²/(hχ)) q_n + ½h(cψ/χ g_n + ψ/χ g_{n+1}),

    g_n = g(φq_n), all functions of h√A (c = cos, s = sin of hω̃)."""

    def __init__(self, a, potential, method, h: float, tol: float):
        self.a, self.h, self.tol = a, h, tol
        self.potential = CompiledPotential(potential, a.shape[0])
        self.functions = _filter_functions(method, h)
        probe = self.functions(np.array([0.0, 0.25, 1.0, 4.0, 9.0]) / h**2)
        self.phi_is_identity = bool(np.all(probe["phi"] == 1.0))
        self.iterations = 0
        self.products = 0

    def apply(self, v: np.ndarray, names: tuple[str, ...]) -> dict:
        out, k = apply_functions(self.a, v, self.functions, names, self.tol)
        self.iterations += k
        self.products += 1
        return out

    def force(self, q: np.ndarray) -> dict:
        """g(φq) and the three products of it the next steps need (and, with φ = 1, U(q) under
        "value", computed with the force)."""
        x = q if self.phi_is_identity else self.apply(q, ("phi",))["phi"]
        value, g = self.potential.evaluate(x)
        out = self.apply(g, ("psi", "psi_over_chi", "c_psi_over_chi"))
        if self.phi_is_identity:
            out["value"] = value
        return out

    def step(self, q: np.ndarray, p: np.ndarray, g: dict) -> tuple[np.ndarray, np.ndarray, dict]:
        h = self.h
        fq = self.apply(q, ("one_minus_cos", "sin2_over_h_chi"))
        fp = self.apply(p, ("one_minus_cos", "chi"))
        q_next = q - fq["one_minus_cos"] + h * fp["chi"] + 0.5 * h * h * g["psi"]
        g_next = self.force(q_next)
        p_next = (p - fp["one_minus_cos"] - fq["sin2_over_h_chi"]
                  + 0.5 * h * (g["c_psi_over_chi"] + g_next["psi_over_chi"]))
        return q_next, p_next, g_next


class CompiledPotential:
    """U and −∇U of one state, compiled once for the whole run."""

    def __init__(self, potential, n: int):
        self.evaluator = _native.built_potential(potential, n)

    def force(self, q: np.ndarray) -> np.ndarray:
        return self.evaluator.evaluate(q[None, :])[1][0]

    def evaluate(self, q: np.ndarray) -> tuple[float, np.ndarray]:
        """(U(q), −∇U(q)) from one evaluation."""
        values, forces = self.evaluator.evaluate(q[None, :])
        return float(values[0]), forces[0]

    def value(self, q: np.ndarray) -> float:
        return float(self.evaluator.evaluate(q[None, :])[0][0])


def energies(a, potential, q: np.ndarray, p: np.ndarray, u: float | None = None) -> np.ndarray:
    """(total, oscillatory, slow) at one state: ½|p|² + ½qᵀAq is H_ω when A has no zero
    eigenvalue (the slow part ½|P₀p|² is not separated on this path), and H_slow = U(q)
    (`u` when it is known)."""
    quadratic = 0.5 * (p @ p + q @ (a @ q))
    u = float(potential.value(q)) if u is None else u
    return np.array([quadratic + u, quadratic, u])


def _finite(q: np.ndarray, p: np.ndarray, u: float) -> bool:
    """The core's test of a state: q, p and U(q) finite (a non-finite force g(φq) makes the
    next momentum, hence the state, non-finite)."""
    return bool(np.all(np.isfinite(q)) and np.all(np.isfinite(p)) and np.isfinite(u))


def _rust_float(x: float) -> str:
    """x as the core prints it in its messages (NaN, inf, -inf)."""
    return "NaN" if np.isnan(x) else ("inf" if x > 0 else "-inf") if np.isinf(x) else repr(x)


def _nothing_integrated(q: np.ndarray, e0: np.ndarray, stepper, tol: float):
    """U(q0) is not finite: like the core, status "blow-up" at step 0 with no samples."""
    n = q.size
    samples = {"q": np.empty((0, n)), "p": np.empty((0, n)), "energies": np.empty((0, 5)), "steps": np.empty(0)}
    message = f"the potential is not finite at the initial state (U(q0) = {_rust_float(e0[2])}); nothing was integrated"
    return _native.run_result(["blow-up"], [message], [0], np.r_[e0, np.nan, e0[1]][None, :],
                              np.full((1, 5), np.nan), [samples], info=_info(stepper, tol))


def _info(stepper, tol: float) -> dict:
    """The Krylov path's counts for ``Solution.info``."""
    return {"iterations": stepper.iterations, "products": stepper.products, "tolerance": tol,
            "iterations_per_product": stepper.iterations / max(stepper.products, 1)}


def integrate(problem, method, q0, p0, h: float, n_steps: int, save_every: int, track: bool, callback,
              tol: float):
    """Runs one trajectory on the Krylov path; returns the core's RunResult, from which
    :func:`trigint.integrate` builds its Solution (states in the user's coordinates, which are
    the only ones here)."""
    a = problem.stiffness
    stepper = KrylovStepper(a, problem.potential, method, h, tol)
    potential = stepper.potential
    q, p = q0.copy(), p0.copy()
    status, message = "completed", f"{n_steps} steps"
    e0 = energies(a, potential, q, p)
    if not np.isfinite(e0[2]):
        return _nothing_integrated(q, e0, stepper, tol)
    steps, qs, ps, es = [0], [q.copy()], [p.copy()], [e0]
    worst = np.zeros(3)
    n = 0
    try:
        g = stepper.force(q)
        while n < n_steps:
            q_next, p_next, g_next = stepper.step(q, p, g)
            u_next = g_next["value"] if "value" in g_next else potential.value(q_next)
            if not _finite(q_next, p_next, u_next):
                status = "blow-up"
                message = (f"the solution blew up: the state is not finite at step {n + 1} (t = {(n + 1) * h:g}); "
                           f"kept the samples up to step {n}, the last finite state")
                break
            q, p, g = q_next, p_next, g_next
            n += 1
            keep = n % save_every == 0 or n == n_steps
            if track or keep:
                e = energies(a, potential, q, p, u_next)
                worst = np.maximum(worst, np.abs(e - e0))
            if keep:
                steps.append(n)
                qs.append(q.copy())
                ps.append(p.copy())
                es.append(e)
            if callback is not None and n % 64 == 0 and callback(n) is False:
                status, message = "interrupted", f"stopped by the progress callback at step {n}"
                break
    except KeyboardInterrupt:
        status, message = "interrupted", f"interrupted at step {n}"
    except KrylovFailure as exc:
        # the products lost their accuracy: stop as a blow-up does, keeping the samples
        status, message = "blow-up", f"stopped before step {n + 1} (t = {(n + 1) * h:g}): {exc}"
    if steps[-1] != n:
        steps.append(n)
        qs.append(q.copy())
        ps.append(p.copy())
        es.append(energies(a, potential, q, p))
    e = np.array(es)
    nan = np.full(len(steps), np.nan)
    table = np.column_stack([e[:, 0], e[:, 1], e[:, 2], nan, e[:, 1]])
    if not track:
        worst = np.full(3, np.nan)
    samples = {"q": np.array(qs), "p": np.array(ps), "energies": table, "steps": np.array(steps, dtype=float)}
    info = _info(stepper, tol)
    return _native.run_result([status], [message], [n], np.r_[e0, np.nan, e0[1]][None, :],
                              np.r_[worst, np.nan, worst[1]][None, :], [samples],
                              interrupted=status == "interrupted", info=info)

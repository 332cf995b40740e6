//! The stepping kernels: the two-step recursion (trigo-mod) and its one-step form.
//!
//! Both are generic over the potential and over the storage of the state, so that for
//! small fixed dimensions the state lives in stack arrays whose loops unroll and stay in
//! registers, while large problems use heap vectors. The arithmetic is the same either way.

use crate::coefficients::KernelCoefficients;
use crate::energy::Recorder;
use crate::error::CoreResult;
use crate::potential::Potential;

/// Storage of one state vector: a fixed-size array or a vector.
pub trait Storage: Clone + Send {
    fn from_slice(values: &[f64]) -> Self;
    fn get(&self) -> &[f64];
    fn get_mut(&mut self) -> &mut [f64];
}

impl<const N: usize> Storage for [f64; N] {
    #[inline(always)]
    fn from_slice(values: &[f64]) -> Self {
        let mut a = [0.0; N];
        a.copy_from_slice(values);
        a
    }
    #[inline(always)]
    fn get(&self) -> &[f64] {
        self
    }
    #[inline(always)]
    fn get_mut(&mut self) -> &mut [f64] {
        self
    }
}

impl Storage for Vec<f64> {
    fn from_slice(values: &[f64]) -> Self {
        values.to_vec()
    }
    #[inline(always)]
    fn get(&self) -> &[f64] {
        self
    }
    #[inline(always)]
    fn get_mut(&mut self) -> &mut [f64] {
        self
    }
}

/// The coefficients copied into the kernel's own storage.
#[derive(Clone)]
struct Coef<S> {
    phi_is_identity: bool,
    one_minus_cos: S,
    two_one_minus_cos: S,
    h2_psi: S,
    half_h2_psi: S,
    phi: S,
    inv_2h_chi: S,
    h_chi: S,
    p_from_q: S,
    half_h_psi0: S,
    half_h_psi1: S,
}

impl<S: Storage> Coef<S> {
    fn new(k: &KernelCoefficients) -> Self {
        Coef {
            phi_is_identity: k.phi_is_identity,
            one_minus_cos: S::from_slice(&k.one_minus_cos),
            two_one_minus_cos: S::from_slice(&k.two_one_minus_cos),
            h2_psi: S::from_slice(&k.h2_psi),
            half_h2_psi: S::from_slice(&k.half_h2_psi),
            phi: S::from_slice(&k.phi),
            inv_2h_chi: S::from_slice(&k.inv_2h_chi),
            h_chi: S::from_slice(&k.h_chi),
            p_from_q: S::from_slice(&k.p_from_q),
            half_h_psi0: S::from_slice(&k.half_h_psi0),
            half_h_psi1: S::from_slice(&k.half_h_psi1),
        }
    }
}

/// g(Φq) into `f`, and U(q) when `with_value` (else NaN). `x` is scratch for Φq.
#[inline(always)]
fn evaluate<P: Potential>(
    pot: &P,
    phi_is_identity: bool,
    phi: &[f64],
    q: &[f64],
    x: &mut [f64],
    f: &mut [f64],
    with_value: bool,
) -> CoreResult<f64> {
    if phi_is_identity {
        if with_value {
            pot.value_and_force(q, f)
        } else {
            pot.force(q, f).map(|_| f64::NAN)
        }
    } else {
        for i in 0..q.len() {
            x[i] = phi[i] * q[i];
        }
        pot.force(x, f)?;
        if with_value {
            pot.value(q)
        } else {
            Ok(f64::NAN)
        }
    }
}

/// A stepping kernel. `start` observes step 0 and moves to step 1; each `step` observes the
/// current step n and moves to n + 1. Both return Ok(false) when the observed state is not
/// finite.
pub trait Stepper {
    /// The storage of the state (and of the recorder's weights).
    type S: Storage;
    fn start(&mut self, q0: &[f64], p0: &[f64], rec: &mut Recorder<Self::S>) -> CoreResult<bool>;
    fn step(&mut self, rec: &mut Recorder<Self::S>) -> CoreResult<bool>;
}

// The loops take every array as its own slice argument: only then does the compiler know that
// they do not overlap (noalias), and long states vectorize.

/// d_{n+1} = d_n − 2(1 − c) q_n + h²ψ g_n and p_n = (d_{n+1} + d_n)/(2hχ), coordinate by coordinate.
#[inline(always)]
fn sweep(q: &[f64], f: &[f64], d: &mut [f64], p: &mut [f64], a: &[f64], hp: &[f64], inv: &[f64]) {
    let n = q.len();
    let (f, d, p, a, hp, inv) = (
        &f[..n],
        &mut d[..n],
        &mut p[..n],
        &a[..n],
        &hp[..n],
        &inv[..n],
    );
    for i in 0..n {
        let next = d[i] - a[i] * q[i] + hp[i] * f[i];
        p[i] = (next + d[i]) * inv[i];
        d[i] = next;
    }
}

/// x += y
#[inline(always)]
fn add_assign(x: &mut [f64], y: &[f64]) {
    let n = x.len();
    let y = &y[..n];
    for i in 0..n {
        x[i] += y[i];
    }
}

/// The two-step form (trigo-mod): q_{n+1} = 2c q_n − q_{n−1} + h²ψ g(φ q_n),
/// p_n = (q_{n+1} − q_{n−1}) / (2hχ); started by (trigo-q1).
///
/// It runs in summed form on d_n = q_n − q_{n−1}, which is the same recursion:
/// d_{n+1} = d_n − 2(1 − c) q_n + h²ψ g(φq_n), q_{n+1} = q_n + d_{n+1},
/// p_n = (d_{n+1} + d_n) / (2hχ). With 1 − c known to full precision this keeps the phase
/// exact to rounding for small hω̃ (as the summed form of Störmer–Verlet does).
pub struct TwoStep<'p, P, S> {
    pot: &'p P,
    k: Coef<S>,
    q: S,
    d: S,
    p: S,
    f: S,
    x: S,
    u: f64,
    n: u64,
}

impl<'p, P: Potential, S: Storage> TwoStep<'p, P, S> {
    pub fn new(pot: &'p P, k: &KernelCoefficients) -> Self {
        let z = S::from_slice(&vec![0.0; k.n]);
        TwoStep {
            pot,
            k: Coef::new(k),
            q: z.clone(),
            d: z.clone(),
            p: z.clone(),
            f: z.clone(),
            x: z,
            u: f64::NAN,
            n: 0,
        }
    }

    #[inline(always)]
    fn evaluate_current(&mut self, with_value: bool) -> CoreResult<()> {
        let k = &self.k;
        self.u = evaluate(
            self.pot,
            k.phi_is_identity,
            k.phi.get(),
            self.q.get(),
            self.x.get_mut(),
            self.f.get_mut(),
            with_value,
        )?;
        Ok(())
    }
}

impl<P: Potential, S: Storage> Stepper for TwoStep<'_, P, S> {
    type S = S;

    fn start(&mut self, q0: &[f64], p0: &[f64], rec: &mut Recorder<S>) -> CoreResult<bool> {
        self.q = S::from_slice(q0);
        self.evaluate_current(true)?;
        if !rec.observe(0, q0, p0, self.u) {
            return Ok(false);
        }
        // (trigo-q1): q_1 = c q_0 + hχ p_0 + ½h²ψ g(φq_0), i.e. d_1 = −(1 − c) q_0 + hχ p_0 + ½h²ψ g_0.
        let k = &self.k;
        let (q, f, d) = (self.q.get_mut(), self.f.get(), self.d.get_mut());
        for i in 0..q.len() {
            d[i] = -(k.one_minus_cos.get()[i] * q[i])
                + k.h_chi.get()[i] * p0[i]
                + k.half_h2_psi.get()[i] * f[i];
            q[i] += d[i];
        }
        self.n = 1;
        let want = rec.needs_potential_at(1);
        self.evaluate_current(want)?;
        Ok(true)
    }

    #[inline(always)]
    fn step(&mut self, rec: &mut Recorder<S>) -> CoreResult<bool> {
        let k = &self.k;
        sweep(
            self.q.get(),
            self.f.get(),
            self.d.get_mut(),
            self.p.get_mut(),
            k.two_one_minus_cos.get(),
            k.h2_psi.get(),
            k.inv_2h_chi.get(),
        );
        if !rec.observe(self.n, self.q.get(), self.p.get(), self.u) {
            return Ok(false);
        }
        add_assign(self.q.get_mut(), self.d.get());
        self.n += 1;
        let want = rec.needs_potential_at(self.n);
        self.evaluate_current(want)?;
        Ok(true)
    }
}

/// The one-step (velocity) form, equivalent to (trigo-mod) in exact arithmetic:
/// q_{n+1} = c q_n + hχ p_n + ½h²ψ g_n,
/// p_{n+1} = −s²/(hχ) q_n + c p_n + ½h (cψ/χ g_n + ψ/χ g_{n+1})   [GNI XIII (2.7)–(2.9)],
/// evaluated as increments, c x = x − (1 − c) x, for the same reason as the two-step form.
pub struct OneStep<'p, P, S> {
    pot: &'p P,
    k: Coef<S>,
    q: S,
    q_next: S,
    p: S,
    f: S,
    f_next: S,
    x: S,
    u: f64,
    n: u64,
}

impl<'p, P: Potential, S: Storage> OneStep<'p, P, S> {
    pub fn new(pot: &'p P, k: &KernelCoefficients) -> Self {
        let z = S::from_slice(&vec![0.0; k.n]);
        OneStep {
            pot,
            k: Coef::new(k),
            q: z.clone(),
            q_next: z.clone(),
            p: z.clone(),
            f: z.clone(),
            f_next: z.clone(),
            x: z,
            u: f64::NAN,
            n: 0,
        }
    }

    /// From (q_n, p_n, g_n) to step n + 1.
    #[inline(always)]
    fn advance(&mut self, rec: &Recorder<S>) -> CoreResult<()> {
        let k = &self.k;
        {
            let (q, p, f, qn) = (
                self.q.get(),
                self.p.get(),
                self.f.get(),
                self.q_next.get_mut(),
            );
            for i in 0..q.len() {
                qn[i] = q[i]
                    + (-(k.one_minus_cos.get()[i] * q[i])
                        + k.h_chi.get()[i] * p[i]
                        + k.half_h2_psi.get()[i] * f[i]);
            }
        }
        let want = rec.needs_potential_at(self.n + 1);
        self.u = evaluate(
            self.pot,
            k.phi_is_identity,
            k.phi.get(),
            self.q_next.get(),
            self.x.get_mut(),
            self.f_next.get_mut(),
            want,
        )?;
        {
            let (q, p, f, fnx) = (
                self.q.get(),
                self.p.get_mut(),
                self.f.get(),
                self.f_next.get(),
            );
            for i in 0..q.len() {
                p[i] += k.p_from_q.get()[i] * q[i] - k.one_minus_cos.get()[i] * p[i]
                    + (k.half_h_psi0.get()[i] * f[i] + k.half_h_psi1.get()[i] * fnx[i]);
            }
        }
        std::mem::swap(&mut self.q, &mut self.q_next);
        std::mem::swap(&mut self.f, &mut self.f_next);
        self.n += 1;
        Ok(())
    }
}

impl<P: Potential, S: Storage> Stepper for OneStep<'_, P, S> {
    type S = S;

    fn start(&mut self, q0: &[f64], p0: &[f64], rec: &mut Recorder<S>) -> CoreResult<bool> {
        self.q = S::from_slice(q0);
        self.p = S::from_slice(p0);
        let k = &self.k;
        self.u = evaluate(
            self.pot,
            k.phi_is_identity,
            k.phi.get(),
            self.q.get(),
            self.x.get_mut(),
            self.f.get_mut(),
            true,
        )?;
        if !rec.observe(0, q0, p0, self.u) {
            return Ok(false);
        }
        self.advance(rec)?;
        Ok(true)
    }

    #[inline(always)]
    fn step(&mut self, rec: &mut Recorder<S>) -> CoreResult<bool> {
        if !rec.observe(self.n, self.q.get(), self.p.get(), self.u) {
            return Ok(false);
        }
        self.advance(rec)?;
        Ok(true)
    }
}

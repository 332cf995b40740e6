//! The step: the recursion (2.5) in its two forms, its start (2.3), and the energy
//! sums of the state it passes through. Written once over [`Real`], so one trajectory (`f64`)
//! and a bundle of lanes (`Lanes<W>`) run the same operations in the same order.
//!
//! Two-step form, evaluated in summed form on d_n = q_n − q_{n−1} (the same recursion):
//!
//!   d_{n+1} = d_n − 2(1 − c) q_n + h²ψ g(φq_n),   q_{n+1} = q_n + d_{n+1},
//!   p_n = (d_{n+1} + d_n) / (2hχ),
//!
//! started by (2.3): d_1 = −(1 − c) q_0 + hχ p_0 + ½h²ψ g(φq_0). With 1 − c = 2 sin²(½hω̃)
//! known to full precision this keeps the phase exact to rounding for small hω̃. On the slow
//! coordinates (c = χ = ψ = φ = 1) it is Störmer–Verlet: d_{n+1} = d_n + h² g_n.
//!
//! One-step (velocity) form [GNI XIII (2.7)–(2.9)], equivalent in exact arithmetic:
//!
//!   q_{n+1} = q_n − (1 − c) q_n + hχ p_n + ½h²ψ g_n,
//!   p_{n+1} = p_n − (1 − c) p_n − (s²/(hχ)) q_n + ½h (cψ/χ g_n + ψ/χ g_{n+1}).

use crate::coefficients::{Coef, Weights};
use crate::energy::{at, kinetic, modified, oscillator, sum, Sums};
use crate::error::CoreResult;
use crate::potential::Potential;
use crate::real::Real;
use crate::shape::{Shape, Storage};
use crate::sum::Sum8;

mod blocks;
mod state_sums;

pub use blocks::{two_step_riding, Riders};
pub use state_sums::sums_of_state;

/// What a step computes besides advancing.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Observe {
    /// Nothing: advance only.
    No,
    /// The energy sums of the current step.
    Energies,
    /// The energy sums, and p_n stored with q_n kept: the state of a sample.
    State,
}

/// The state of a bundle between steps, with its force already evaluated.
pub struct State<L: Real, Sh: Shape> {
    pub q: Sh::S<L>,
    /// Two-step: d_n = q_n − q_{n−1}. One-step: unused.
    pub d: Sh::S<L>,
    /// p_n once observed (two-step), or the momentum (one-step).
    pub p: Sh::S<L>,
    /// g(φ q_n)
    pub f: Sh::S<L>,
    /// Scratch for φ q_n.
    pub x: Sh::S<L>,
    /// One-step: q_{n+1} before it becomes q, then q_n.
    pub q_next: Sh::S<L>,
    /// One-step: g_n while g_{n+1} is evaluated.
    pub f_prev: Sh::S<L>,
    /// U(q_n) when it was asked for.
    pub u: L,
}

impl<L: Real, Sh: Shape> State<L, Sh> {
    /// A state that owns no memory, to stand in while the real one is moved out.
    #[inline(always)]
    pub fn placeholder() -> Self {
        Self::from_rows(Sh::S::<L>::placeholder)
    }

    #[inline(always)]
    pub fn new(sh: &Sh) -> Self {
        Self::from_rows(|| Sh::S::<L>::filled(sh.n(), L::zero()))
    }

    /// The rows a bundle stepping in this form reads. q and p hold the trajectories' initial
    /// values, written once (lane b from row b of `q0` and `p0`; lanes beyond the rows repeat
    /// the last one); the other rows it reads are zeroed, and those it does not read own no
    /// memory (on a 2¹⁶-point wave, three 512 KiB rows a call does not zero). φq's scratch `x`
    /// is read only where φ is not the identity; `q_next` by the one-step form, and by the lane
    /// loop as U's scratch where φ is not the identity; `f_prev` by the one-step form only.
    pub fn for_steps(
        sh: &Sh,
        one_step: bool,
        phi_is_identity: bool,
        (q0, p0): (&[&[f64]], &[&[f64]]),
    ) -> Self {
        let initial = |rows: &[&[f64]]| {
            if L::LANES == 1 {
                // one trajectory: a copy (a loop the compiler vectorizes)
                let row = &rows[0][..sh.n()];
                return Sh::S::<L>::from_fn(sh.n(), |i| L::splat(row[i]));
            }
            Sh::S::<L>::from_fn(sh.n(), |i| {
                let mut x = L::zero();
                for b in 0..L::LANES {
                    x.set_lane(b, rows[b.min(rows.len() - 1)][i]);
                }
                x
            })
        };
        let row = |read: bool| {
            if read {
                Sh::S::<L>::filled(sh.n(), L::zero())
            } else {
                Sh::S::<L>::placeholder()
            }
        };
        State {
            q: initial(q0),
            d: row(true),
            p: initial(p0),
            f: row(true),
            x: row(!phi_is_identity),
            q_next: row(one_step || !phi_is_identity),
            f_prev: row(one_step),
            u: L::zero(),
        }
    }

    /// Every row from `row()`, U zero.
    #[inline(always)]
    fn from_rows(row: impl Fn() -> Sh::S<L>) -> Self {
        State {
            q: row(),
            d: row(),
            p: row(),
            f: row(),
            x: row(),
            q_next: row(),
            f_prev: row(),
            u: L::zero(),
        }
    }
}

/// The force g(φq) of the state's q into its `f`, and U(q) into `u` when `with_value`.
/// `phi_is_identity` is the coefficients' flag, passed as a constant where the caller knows it;
/// `inline` takes the potential's [`inline_force`](Potential::inline_force) (the same numbers).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn evaluate<L: Real, Sh: Shape, P: Potential>(
    sh: &Sh,
    pot: &P,
    ws: &mut P::Workspace<L>,
    k: &Coef<L, Sh::S<L>>,
    st: &mut State<L, Sh>,
    with_value: bool,
    phi_is_identity: bool,
    inline: bool,
) -> CoreResult<()> {
    if phi_is_identity {
        if inline {
            st.u = pot.inline_force(st.q.get(), st.f.get_mut(), with_value);
        } else {
            pot.force_into(st.q.get(), st.f.get_mut(), with_value, ws, &mut st.u)?;
        }
        return Ok(());
    }
    let (q, x, phi) = (st.q.get(), st.x.get_mut(), k.phi.get());
    x[..sh.ns()].copy_from_slice(&q[..sh.ns()]);
    for i in sh.ns()..sh.n() {
        x[i] = at(phi, sh.coef(i)) * q[i];
    }
    if inline {
        pot.inline_force(st.x.get(), st.f.get_mut(), false);
        if with_value {
            // U as `value` gives it: a force pass at q, its forces (into φq's scratch) unused.
            st.u = pot.inline_force(st.q.get(), st.x.get_mut(), true);
        }
    } else {
        pot.force(st.x.get(), st.f.get_mut(), false, ws)?;
        if with_value {
            pot.value_into(st.q.get(), ws, &mut st.u)?;
        }
    }
    Ok(())
}

/// One oscillatory coordinate of the two-step form: from (d_n, q_n, g_n) and its numbers
/// (2(1 − c), h²ψ, 1/(2hχ), ω², H* weights), d_{n+1}, p_n and its energy terms (p² + ω²q²,
/// and a p² + b q² unless H* is H_ω).
#[inline(always)]
fn fast_term<L: Real>(d: L, q: L, f: L, k: [L; 6], plain: bool) -> (L, L, L, L) {
    let [a, hp, inv, w2, mp, mq] = k;
    let next = d - a * q + hp * f;
    let p = (next + d) * inv;
    let m = if plain {
        L::zero()
    } else {
        modified(p, q, mp, mq)
    };
    (next, p, oscillator(p, q, w2), m)
}

/// One slow coordinate (Störmer–Verlet): d_{n+1}, p_n and p².
#[inline(always)]
fn slow_term<L: Real>(d: L, f: L, h2: L, inv_2h: L) -> (L, L, L) {
    let next = d + h2 * f;
    let p = (next + d) * inv_2h;
    (next, p, kinetic(p))
}

/// One coordinate's work in an observing sweep: from (i, d_i, q_i), its new d, p_n and its two
/// energy terms. (A trait with an `#[inline(always)]` method rather than a closure: closures
/// called from two places are not reliably inlined.)
trait Term<L> {
    fn at(&self, i: usize, d: L, q: L, f: L) -> (L, L, L, L);
}

struct SlowTerms<L> {
    h2: L,
    inv_2h: L,
}

impl<L: Real> Term<L> for SlowTerms<L> {
    #[inline(always)]
    fn at(&self, _: usize, d: L, _: L, f: L) -> (L, L, L, L) {
        let (next, p, e) = slow_term(d, f, self.h2, self.inv_2h);
        (next, p, e, L::zero())
    }
}

/// Oscillatory coordinates reading their numbers (2(1 − c), h²ψ, 1/(2hχ), ω², H* weights) from
/// rows, at the shape's `coef(i)` (a constant for [`Fixed`](crate::shape::Fixed) shapes).
struct FastRows<'a, L, Sh> {
    sh: &'a Sh,
    rows: [&'a [L]; 6],
    plain: bool,
}

impl<L: Real, Sh: Shape> Term<L> for FastRows<'_, L, Sh> {
    #[inline(always)]
    fn at(&self, i: usize, d: L, q: L, f: L) -> (L, L, L, L) {
        let (r, c) = (&self.rows, self.sh.coef(i));
        let k = [
            at(r[0], c),
            at(r[1], c),
            at(r[2], c),
            at(r[3], c),
            at(r[4], c),
            at(r[5], c),
        ];
        fast_term(d, q, f, k, self.plain)
    }
}

/// Oscillatory coordinates of a run-time uniform block: one set of numbers, loaded before the
/// loop (a load from a row inside it would stop the compiler from vectorizing the loop).
struct FastUniform<L> {
    k: [L; 6],
    plain: bool,
}

impl<L: Real> Term<L> for FastUniform<L> {
    #[inline(always)]
    fn at(&self, _: usize, d: L, q: L, f: L) -> (L, L, L, L) {
        fast_term(d, q, f, self.k, self.plain)
    }
}

#[inline(always)]
fn load8<L: Copy>(x: &[L], base: usize) -> [L; 8] {
    x[base..base + 8].try_into().expect("a chunk of eight")
}

/// Coordinates base..base+8 of [`observe_range`] through local arrays; the first chunk of a
/// range starts the eight partial sums, later ones add to them.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn chunk<L: Real, T: Term<L>, const FIRST: bool, const STORE: bool>(
    base: usize,
    (q, d, p, f): (&mut [L], &mut [L], &mut [L], &[L]),
    term: &T,
    e: &mut Sum8<L>,
    m: &mut Sum8<L>,
) {
    let (dc, qc, fc) = (load8(d, base), load8(q, base), load8(f, base));
    let (mut next, mut pc, mut qn) = ([L::zero(); 8], [L::zero(); 8], qc);
    for t in 0..8 {
        let (x, y, ee, mm) = term.at(base + t, dc[t], qc[t], fc[t]);
        (next[t], pc[t], qn[t]) = (x, y, qc[t] + x);
        e.add(t, !FIRST, ee);
        m.add(t, !FIRST, mm);
    }
    d[base..base + 8].copy_from_slice(&next);
    if STORE {
        p[base..base + 8].copy_from_slice(&pc);
    } else {
        q[base..base + 8].copy_from_slice(&qn);
    }
}

/// The whole chunks of eight of [`observe_range`] from `start` (at least one); returns where
/// they end.
#[inline(always)]
fn chunks<L: Real, T: Term<L>, const STORE: bool>(
    start: usize,
    end: usize,
    (q, d, p, f): (&mut [L], &mut [L], &mut [L], &[L]),
    term: &T,
    e: &mut Sum8<L>,
    m: &mut Sum8<L>,
) -> usize {
    chunk::<L, T, true, STORE>(start, (q, d, p, f), term, e, m);
    let mut base = start + 8;
    while base + 8 <= end {
        chunk::<L, T, false, STORE>(base, (q, d, p, f), term, e, m);
        base += 8;
    }
    base
}

/// Observing sweep over coordinates start..end: each coordinate's `term` (its new d, p and two
/// energy terms), q advanced unless `store` (then p is stored), and the energy terms summed in
/// the kernels' order (see [`crate::sum`]). Chunks of eight go through local
/// arrays, which cannot alias the state, so the compiler vectorizes them.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn observe_range<L: Real, T: Term<L>>(
    start: usize,
    end: usize,
    (q, d, p, f): (&mut [L], &mut [L], &mut [L], &[L]),
    store: bool,
    term: &T,
) -> (L, L) {
    let count = end - start;
    let (mut e, mut m) = (Sum8::new(), Sum8::new());
    let mut base = start;
    if base + 8 <= end {
        // (`store` decided outside the loop: tested inside it, LLVM kept both p's and q's new
        // chunks on the stack and copied the one chosen through a pointer, at every chunk. One
        // streamed step of the FPU problem with m = 1000, AVX-512 copy on an AMD Zen 5:
        // 1110-1320 ns with that, 820-930 without, alternated processes.)
        base = if store {
            chunks::<L, T, true>(start, end, (q, d, p, f), term, &mut e, &mut m)
        } else {
            chunks::<L, T, false>(start, end, (q, d, p, f), term, &mut e, &mut m)
        };
    }
    let started = count >= 8;
    for t in 0..end - base {
        let i = base + t;
        let (x, y, ee, mm) = term.at(i, d[i], q[i], f[i]);
        d[i] = x;
        if store {
            p[i] = y;
        } else {
            q[i] += x;
        }
        e.add(t, started, ee);
        m.add(t, started, mm);
    }
    (e.total(count), m.total(count))
}

/// Two-step form: observes step n (when asked) and moves the state from n to n + 1, except the
/// force at q_{n+1} (see [`evaluate`]), which must be in `f` already. Observing takes the energy
/// sums of (q_n, p_n) in one pass with the step (the forms and summation order of
/// [`sums_of_state`], so the same bits); for ℓ > 1 the per-block sums Σ(p² + ω²q²) go to
/// `blocks` (except where the blocks' extremes ride an [`Observe::Energies`] sweep: they are
/// taken there, and `blocks` is scratch). With [`Observe::State`], p_n is stored and q is left
/// at q_n (after [`Observe::Energies`], `p` holds no p_n: it may be scratch);
/// [`finish_state_step`] then completes the step. `plain` is the weights' `plain_modified`,
/// passed as a constant where the caller knows it so that no test is left in the loops.
#[inline(always)]
pub fn two_step<L: Real, Sh: Shape>(
    sh: &Sh,
    k: &Coef<L, Sh::S<L>>,
    w: &Weights<L, Sh::S<L>>,
    st: &mut State<L, Sh>,
    obs: Observe,
    plain: bool,
    blocks: &mut [L],
) -> Sums<L> {
    two_step_riding(sh, k, w, st, obs, plain, blocks, Riders::none())
}

/// The state's rows (q, d, p, f), over the shape's coordinates.
#[inline(always)]
#[allow(clippy::type_complexity)]
fn state_rows<'a, L: Real, Sh: Shape>(
    sh: &Sh,
    st: &'a mut State<L, Sh>,
) -> (&'a mut [L], &'a mut [L], &'a mut [L], &'a [L]) {
    let n = sh.n();
    (
        &mut st.q.get_mut()[..n],
        &mut st.d.get_mut()[..n],
        &mut st.p.get_mut()[..n],
        &st.f.get()[..n],
    )
}

/// The observing sweep of the slow coordinates 0..ns (Störmer–Verlet): their kinetic sum.
#[inline(always)]
fn observe_slow<L: Real, S>(
    ns: usize,
    k: &Coef<L, S>,
    rows: (&mut [L], &mut [L], &mut [L], &[L]),
    store: bool,
) -> L {
    let slow = SlowTerms {
        h2: k.h2,
        inv_2h: k.inv_2h,
    };
    observe_range(0, ns, rows, store, &slow).0
}

/// The rows of numbers an observing step reads: 2(1 − c), h²ψ, 1/(2hχ), ω² and H*'s weights.
#[inline(always)]
fn step_rows<'a, L: Real, Sh: Shape>(
    sh: &Sh,
    k: &'a Coef<L, Sh::S<L>>,
    w: &'a Weights<L, Sh::S<L>>,
) -> [&'a [L]; 6] {
    let n = sh.n();
    [
        &k.two_omc.get()[..n],
        &k.h2_psi.get()[..n],
        &k.inv_2h_chi.get()[..n],
        &w.omega2.get()[..n],
        &w.modified_p.get()[..n],
        &w.modified_q.get()[..n],
    ]
}

/// [`two_step`] of a shape of one block, or of any shape unobserved: everything but the sweep
/// of many blocks, whose code is not in it. The lane loops and every unobserved step call this:
/// with that sweep's code inlined beside theirs (dead for their shapes, but there through part
/// of the compiler's passes), an edit of that sweep once left the FPU lane loop unvectorized
/// (1000 lanes: 1.25 → 10 ns per trajectory-step, AMD Zen 5).
#[inline(always)]
pub fn two_step_one_block<L: Real, Sh: Shape>(
    sh: &Sh,
    k: &Coef<L, Sh::S<L>>,
    w: &Weights<L, Sh::S<L>>,
    st: &mut State<L, Sh>,
    obs: Observe,
    plain: bool,
) -> Sums<L> {
    debug_assert!(obs == Observe::No || sh.single_block());
    let (ns, n) = (sh.ns(), sh.n());
    let (q, d, p, f) = state_rows(sh, st);
    let rows = step_rows(sh, k, w);
    let [a, hp, ..] = rows;
    if obs == Observe::No {
        // Slow coordinates: Störmer–Verlet, d_{n+1} = d_n + h² g_n.
        for i in 0..ns {
            d[i] += k.h2 * f[i];
            q[i] += d[i];
        }
        // Oscillatory coordinates: d_{n+1} = d_n − 2(1 − c) q_n + h²ψ g_n.
        match sh.uniform().filter(|_| !Sh::FIXED) {
            Some(c) => {
                let (ac, hc) = (a[c], hp[c]);
                for i in ns..n {
                    d[i] = d[i] - ac * q[i] + hc * f[i];
                    q[i] += d[i];
                }
            }
            None => {
                for i in ns..n {
                    let c = sh.coef(i);
                    d[i] = d[i] - at(a, c) * q[i] + at(hp, c) * f[i];
                    q[i] += d[i];
                }
            }
        }
        return Sums::zero();
    }
    let store = obs == Observe::State;
    let mut sums = Sums::zero();
    sums.0[sum::KINETIC] = observe_slow(ns, k, (q, d, p, f), store);
    if let (Some(c), false) = (sh.uniform(), Sh::FIXED) {
        // One block (the uniform shapes have one).
        let fast = FastUniform {
            k: rows.map(|r| r[c]),
            plain,
        };
        (sums.0[sum::OSCILLATOR], sums.0[sum::MODIFIED]) =
            observe_range(ns, n, (q, d, p, f), store, &fast);
        return sums;
    }
    let fast = FastRows { sh, rows, plain };
    (sums.0[sum::OSCILLATOR], sums.0[sum::MODIFIED]) =
        observe_range(ns, n, (q, d, p, f), store, &fast);
    sums
}

/// p_n = (d_{n+1} + d_n)/(2hχ) into `p`, from d_{n+1} (the state's d after an unobserved
/// two-step step) and d_n: the p_n of an observing step, bit for bit.
#[inline(always)]
pub fn momenta_after_step<L: Real, Sh: Shape>(
    sh: &Sh,
    k: &Coef<L, Sh::S<L>>,
    d_next: &[L],
    d: &[L],
    p: &mut [L],
) {
    let (ns, n) = (sh.ns(), sh.n());
    let inv = k.inv_2h_chi.get();
    for i in 0..ns {
        p[i] = (d_next[i] + d[i]) * k.inv_2h;
    }
    for i in ns..n {
        p[i] = (d_next[i] + d[i]) * at(inv, sh.coef(i));
    }
}

/// After a two-step [`Observe::State`] step: q_{n+1} = q_n + d_{n+1}.
#[inline(always)]
pub fn finish_state_step<L: Real, Sh: Shape>(sh: &Sh, st: &mut State<L, Sh>) {
    let n = sh.n();
    let (q, d) = (&mut st.q.get_mut()[..n], &st.d.get()[..n]);
    for i in 0..n {
        q[i] += d[i];
    }
}

/// (2.3) in summed form: d_1 = −(1 − c) q_0 + hχ p_0 + ½h²ψ g_0, q_1 = q_0 + d_1, with
/// p_0 in `st.p` and g_0 in `st.f`.
#[inline(always)]
pub fn two_step_start<L: Real, Sh: Shape>(sh: &Sh, k: &Coef<L, Sh::S<L>>, st: &mut State<L, Sh>) {
    let (ns, n) = (sh.ns(), sh.n());
    let (q, d) = (st.q.get_mut(), st.d.get_mut());
    let (p, f) = (st.p.get(), st.f.get());
    let (omc, hchi, half) = (k.omc.get(), k.h_chi.get(), k.half_h2_psi.get());
    for i in 0..ns {
        d[i] = k.h * p[i] + k.half_h2 * f[i];
        q[i] += d[i];
    }
    for i in ns..n {
        let c = sh.coef(i);
        d[i] = -(at(omc, c) * q[i]) + at(hchi, c) * p[i] + at(half, c) * f[i];
        q[i] += d[i];
    }
}

/// One-step form, first half: q_{n+1} from (q_n, p_n, g_n); afterwards `q` holds q_{n+1},
/// `q_next` holds q_n and `f_prev` holds g_n, and g_{n+1} is to be evaluated into `f`.
#[inline(always)]
pub fn one_step_position<L: Real, Sh: Shape>(
    sh: &Sh,
    k: &Coef<L, Sh::S<L>>,
    st: &mut State<L, Sh>,
) {
    let (ns, n) = (sh.ns(), sh.n());
    {
        let (q, p, f) = (st.q.get(), st.p.get(), st.f.get());
        let qn = st.q_next.get_mut();
        let (omc, hchi, half) = (k.omc.get(), k.h_chi.get(), k.half_h2_psi.get());
        for i in 0..ns {
            qn[i] = q[i] + (k.h * p[i] + k.half_h2 * f[i]);
        }
        for i in ns..n {
            let c = sh.coef(i);
            qn[i] = q[i] + (-(at(omc, c) * q[i]) + at(hchi, c) * p[i] + at(half, c) * f[i]);
        }
    }
    std::mem::swap(&mut st.q, &mut st.q_next);
    std::mem::swap(&mut st.f, &mut st.f_prev);
}

/// One-step form, second half: p_{n+1} from q_n, p_n, g_n and g_{n+1}.
#[inline(always)]
pub fn one_step_momentum<L: Real, Sh: Shape>(
    sh: &Sh,
    k: &Coef<L, Sh::S<L>>,
    st: &mut State<L, Sh>,
) {
    let (ns, n) = (sh.ns(), sh.n());
    let (q, f, fnext) = (st.q_next.get(), st.f_prev.get(), st.f.get());
    let p = st.p.get_mut();
    let (pq, omc, h0, h1) = (
        k.p_from_q.get(),
        k.omc.get(),
        k.half_h_psi0.get(),
        k.half_h_psi1.get(),
    );
    for i in 0..ns {
        p[i] += k.half_h * f[i] + k.half_h * fnext[i];
    }
    for i in ns..n {
        let c = sh.coef(i);
        p[i] += at(pq, c) * q[i] - at(omc, c) * p[i] + (at(h0, c) * f[i] + at(h1, c) * fnext[i]);
    }
}

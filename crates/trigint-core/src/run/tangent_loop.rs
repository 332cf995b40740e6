//! The bundled tangent's tight loop (see [`tangent_lanes`](super::tangent_lanes)): per step,
//! a loop over the lanes for the trajectories (keeping φq_n of each), then one per deviation
//! vector, each body one trajectory's numbers in `f64`, which the compiler vectorizes across
//! the lanes as it does the bundle's lane loop ([`lanes`](super::lanes)). The same operations
//! in the same order as the careful step's bundle arithmetic: the same bits.

use super::bundle::CHECK;
use super::lanes::{evaluate as lane_force, set};
use crate::coefficients::{Coef, Weights};
use crate::energy::at;
use crate::potential::Potential;
use crate::real::{LaneSet, Real};
use crate::recursion::{self, Observe, State};
use crate::shape::{Shape, Storage};

/// The re-orthonormalization of a single deviation vector inside the loop: at the steps that
/// are multiples of `every` (0: never), and at the first step for the lanes `ends`, δq_{n+1}
/// and δd_{n+1} are divided by ‖(δq_n, δp_n)‖ in the metric (the numbers of
/// [`Renormalizer::renormalize`](super::Renormalizer) with one vector), the norms kept in
/// `norms` with their step and lanes.
pub(super) struct Renorm<'a, L> {
    pub(super) every: u64,
    pub(super) ends: LaneSet,
    pub(super) metric: &'a [f64],
    pub(super) norms: &'a mut Vec<(u64, L, LaneSet)>,
    /// Scratch for δq_n and δd_n at a re-orthonormalization.
    pub(super) dq_n: &'a mut [L],
    pub(super) dd_n: &'a mut [L],
}

/// Steps n..e−1 of the trajectories `st` and their deviations `dev` (each a state of the
/// recursion), `xs` the scratch row of φq_n, in the copy for this CPU's vectors. Returns a step
/// at or before which a lane of `active` turned non-finite.
#[allow(clippy::too_many_arguments)]
pub(super) fn lane_loop<L: Real, Sh: Shape, P: Potential, const PHI: bool>(
    sh: &Sh,
    pot: &P,
    k: &Coef<L, Sh::S<L>>,
    w: &Weights<L, Sh::S<L>>,
    st: &mut State<L, Sh>,
    dev: &mut [State<L, Sh>],
    xs: &mut Sh::S<L>,
    renorm: Renorm<'_, L>,
    active: LaneSet,
    n: u64,
    e: u64,
) -> Option<u64> {
    let mut kernel = TangentLoop::<L, Sh, P, PHI> {
        sh,
        pot,
        k,
        w,
        st,
        dev,
        xs,
        renorm,
        active,
        n,
        e,
    };
    crate::isa::run(&mut kernel)
}

struct TangentLoop<'a, L: Real, Sh: Shape, P, const PHI: bool> {
    sh: &'a Sh,
    pot: &'a P,
    k: &'a Coef<L, Sh::S<L>>,
    w: &'a Weights<L, Sh::S<L>>,
    st: &'a mut State<L, Sh>,
    dev: &'a mut [State<L, Sh>],
    xs: &'a mut Sh::S<L>,
    renorm: Renorm<'a, L>,
    active: LaneSet,
    n: u64,
    e: u64,
}

/// Rows of lanes (lane b of number i at `i * width + b`) as plain `f64` slices.
macro_rules! views {
    ($($x:expr),*) => {
        ($(L::as_f64s_mut($x).expect("lanes without padding (checked before the lane loop)"),)*)
    };
}

impl<L: Real, Sh: Shape, P: Potential, const PHI: bool> crate::isa::Kernel
    for TangentLoop<'_, L, Sh, P, PHI>
{
    type Output = Option<u64>;

    #[inline(always)]
    fn run(&mut self) -> Option<u64> {
        self.run_for(64)
    }

    const PLANNED: bool = true;

    /// (A careful step's single step runs in the widest copy: too short to time.)
    fn steps(&self) -> Option<(u64, u64)> {
        (self.e > self.n + 1).then_some((self.n, self.e))
    }

    fn set_steps(&mut self, n: u64, e: u64) {
        (self.n, self.e) = (n, e);
    }

    fn size(&self) -> usize {
        self.sh.n()
    }

    fn stops_early(out: &Option<u64>) -> bool {
        out.is_some()
    }

    #[inline(always)]
    fn run_for(&mut self, vector_bytes: usize) -> Option<u64> {
        // As the bundle's lane loop: with 16 vector registers (AVX2), four lanes at a time.
        let group = if vector_bytes == 32 { 4 } else { L::LANES };
        let (sh, pot, k, w) = (self.sh, self.pot, self.k, self.w);
        let width = L::LANES;
        let rows = sh.n() * width;
        for j in self.n..self.e {
            let every = self.renorm.every;
            {
                let (q, d, xs) =
                    views!(self.st.q.get_mut(), self.st.d.get_mut(), self.xs.get_mut());
                let (q, d, xs) = (&mut q[..rows], &mut d[..rows], &mut xs[..rows]);
                let mut first = 0;
                while first < width {
                    let last = (first + group).min(width);
                    trajectory_lanes::<L, Sh, P, PHI>(sh, pot, k, w, q, d, xs, first..last);
                    barrier(last < width);
                    first = last;
                }
            }
            let due = if every > 0 && j % every == 0 {
                LaneSet::first(width)
            } else if j == self.n {
                self.renorm.ends
            } else {
                LaneSet::EMPTY
            };
            if !due.is_empty() {
                // the single vector's δq_n and δd_n, for its norm after the step
                let dev = &self.dev[0];
                self.renorm.dq_n.copy_from_slice(&dev.q.get()[..sh.n()]);
                self.renorm.dd_n.copy_from_slice(&dev.d.get()[..sh.n()]);
            }
            for dev in self.dev.iter_mut() {
                let (dq, dd, xs) = views!(dev.q.get_mut(), dev.d.get_mut(), self.xs.get_mut());
                let (dq, dd, xs) = (&mut dq[..rows], &mut dd[..rows], &xs[..rows]);
                let mut first = 0;
                while first < width {
                    let last = (first + group).min(width);
                    deviation_lanes::<L, Sh, P, PHI>(sh, pot, k, w, dq, dd, xs, first..last);
                    barrier(last < width);
                    first = last;
                }
            }
            if !due.is_empty() {
                let norms = divided_by_norm(sh, k, &mut self.dev[0], &self.renorm, due);
                self.renorm.norms.push((j, norms, due));
            }
            if j % CHECK == 0 || j + 1 == self.e {
                if let Some(j) = self.nonfinite_at(j, rows) {
                    return Some(j);
                }
            }
        }
        None
    }
}

impl<L: Real, Sh: Shape, P: Potential, const PHI: bool> TangentLoop<'_, L, Sh, P, PHI> {
    /// `Some(j)` if a running lane's trajectory or deviation is not finite.
    #[inline(always)]
    fn nonfinite_at(&self, j: u64, rows: usize) -> Option<u64> {
        let width = L::LANES;
        let mut bad = LaneSet::EMPTY;
        for s in std::iter::once(&*self.st).chain(self.dev.iter()) {
            let q = L::as_f64s(s.q.get()).expect("lanes without padding");
            for (t, x) in q[..rows].iter().enumerate() {
                bad.insert_if(t % width, !x.is_finite());
            }
        }
        (!(bad & self.active).is_empty()).then_some(j)
    }
}

/// Between lane groups: an empty instruction that keeps the compiler from moving memory
/// accesses across it, so that one group's steps are not interleaved with the next's.
#[inline(always)]
fn barrier(yes: bool) {
    if yes {
        // SAFETY: an empty instruction.
        unsafe { std::arch::asm!("", options(nostack, preserves_flags)) };
    }
}

/// The lanes' trajectory step in `f64`, φq_n written to `xs` first. The rows come in as
/// separate slices (mutable borrows, so known not to overlap): the compiler vectorizes the
/// loop over the lanes without run-time overlap tests.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn trajectory_lanes<L: Real, Sh: Shape, P: Potential, const PHI: bool>(
    sh: &Sh,
    pot: &P,
    k: &Coef<L, Sh::S<L>>,
    w: &Weights<L, Sh::S<L>>,
    q: &mut [f64],
    d: &mut [f64],
    xs: &mut [f64],
    lanes: std::ops::Range<usize>,
) {
    let (width, n) = (L::LANES, sh.n());
    for b in lanes {
        let kb: Coef<f64, Sh::S<f64>> = k.lane(b);
        let mut s = State::<f64, Sh>::new(sh);
        for i in 0..n {
            s.q.get_mut()[i] = at(q, i * width + b);
            s.d.get_mut()[i] = at(d, i * width + b);
        }
        lane_force::<Sh, P, PHI>(sh, pot, &kb, &mut s, false);
        let x = if PHI { s.q.get() } else { s.x.get() };
        for i in 0..n {
            set(xs, i * width + b, x[i]);
        }
        let wb: Weights<f64, Sh::S<f64>> = w.lane(b);
        recursion::two_step_one_block(sh, &kb, &wb, &mut s, Observe::No, true);
        for i in 0..n {
            set(q, i * width + b, s.q.get()[i]);
            set(d, i * width + b, s.d.get()[i]);
        }
    }
}

/// The lanes' step of one deviation vector in `f64`: G(φq_n)φδq_n, then the recursion.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn deviation_lanes<L: Real, Sh: Shape, P: Potential, const PHI: bool>(
    sh: &Sh,
    pot: &P,
    k: &Coef<L, Sh::S<L>>,
    w: &Weights<L, Sh::S<L>>,
    dq: &mut [f64],
    dd: &mut [f64],
    xs: &[f64],
    lanes: std::ops::Range<usize>,
) {
    let (width, n) = (L::LANES, sh.n());
    for b in lanes {
        let kb: Coef<f64, Sh::S<f64>> = k.lane(b);
        let mut s = State::<f64, Sh>::new(sh);
        let mut v = Sh::S::<f64>::filled(n, 0.0);
        for i in 0..n {
            s.x.get_mut()[i] = at(xs, i * width + b);
            s.q.get_mut()[i] = at(dq, i * width + b);
            s.d.get_mut()[i] = at(dd, i * width + b);
        }
        scaled_deviation(sh, &kb, PHI, s.q.get(), v.get_mut());
        pot.inline_force_derivative(s.x.get(), v.get(), s.f.get_mut());
        let wb: Weights<f64, Sh::S<f64>> = w.lane(b);
        recursion::two_step_one_block(sh, &kb, &wb, &mut s, Observe::No, true);
        for i in 0..n {
            set(dq, i * width + b, s.q.get()[i]);
            set(dd, i * width + b, s.d.get()[i]);
        }
    }
}

/// After the step of the single vector at a re-orthonormalization: δp_n (as
/// [`recursion::momenta_after_step`] completes it, into `dev.p`), the norm ‖(δq_n, δp_n)‖ in
/// the metric (the one-trajectory sum's order), and δq_{n+1}, δd_{n+1} divided by it in the
/// lanes `due` (times 1/‖·‖, as everywhere). In the bundle's arithmetic: per lane the numbers of
/// [`Renormalizer::renormalize`](super::Renormalizer) with one vector, and vector instructions
/// (the same lines as a loop over lanes in `f64` compiled to scalar code, about a third of the
/// lane loop's time on an Intel Xeon). Returns the norms.
#[inline(always)]
fn divided_by_norm<L: Real, Sh: Shape>(
    sh: &Sh,
    k: &Coef<L, Sh::S<L>>,
    dev: &mut State<L, Sh>,
    renorm: &Renorm<'_, L>,
    due: LaneSet,
) -> L {
    let n = sh.n();
    recursion::momenta_after_step(sh, k, dev.d.get(), renorm.dd_n, dev.p.get_mut());
    let (q_n, p_n) = (&renorm.dq_n[..n], &dev.p.get()[..n]);
    let mut sum = L::zero();
    for i in 0..n {
        sum += L::splat(renorm.metric[i]) * (q_n[i] * q_n[i] + p_n[i] * p_n[i]);
    }
    let norm = sum.sqrt();
    let mut inv = L::splat(1.0) / norm;
    for l in 0..L::LANES {
        if !due.contains(l) {
            inv.set_lane(l, 1.0);
        }
    }
    for row in [dev.q.get_mut(), dev.d.get_mut()] {
        for x in row[..n].iter_mut() {
            *x *= inv;
        }
    }
    norm
}

/// φδq into `v` (δq itself on the slow coordinates, where φ(0) = 1, and when φ ≡ 1).
#[inline(always)]
pub(super) fn scaled_deviation<L: Real, Sh: Shape>(
    sh: &Sh,
    k: &Coef<L, Sh::S<L>>,
    phi_identity: bool,
    dq: &[L],
    v: &mut [L],
) {
    let (ns, n) = (sh.ns(), sh.n());
    v[..n].copy_from_slice(&dq[..n]);
    if !phi_identity {
        let phi = k.phi.get();
        for i in ns..n {
            v[i] = at(phi, sh.coef(i)) * dq[i];
        }
    }
}

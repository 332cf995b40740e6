//! The tight loop of a bundle on a compile-time shape, written as a loop over its lanes whose
//! body is one trajectory's step in `f64`: the compiler vectorizes that loop across the lanes,
//! each lane in its own vector slot, as it does the straight-line C loop over trajectories.
//!
//! Why not the bundle's own arithmetic ([`Lanes`](crate::real::Lanes)): its values are arrays,
//! which the optimizer takes apart into single numbers and packs again as it sees fit. In the
//! step's energy sums and extremes it packs them across the lanes (shuffles, mixed vector
//! widths, spills: 5.0 ns per trajectory-step against the C loop's 1.9 on AMD Zen 4, FPU m = 3,
//! energies streamed). A loop over the lanes leaves it nothing to repack.
//!
//! A force that is a call (compiled programs: `Potential::ROW_FORCE`) cannot be inlined into
//! that loop: it is made for every lane at once on the bundle's rows, and the rest of each
//! lane's step reads it from there (FPU m = 3 as an expression, 1000 trajectories, AMD Zen 5:
//! 4.36 → 3.35 ns per trajectory-step with U written in place, see `Potential::value_into`).
//!
//! The same operations in the same order as [`hot`](super::hot) on `f64`: the same bits.

use super::bundle::{Bundle, CHECK};
use crate::coefficients::{Coef, Weights};
use crate::energy::{at, Extremes, FIRST_BLOCK, MODIFIED, TOTAL};
use crate::error::CoreResult;
use crate::potential::Potential;
use crate::real::{LaneSet, Real};
use crate::recursion::{self, Observe, State};
use crate::shape::{Shape, Storage};

impl<L: Real, Sh: Shape, P: Potential> Bundle<'_, L, Sh, P> {
    /// Whether [`lane_loop`](Self::lane_loop) runs this bundle's tight loop: a compile-time
    /// shape (one block, no pair forms), a bundle of more than one lane without padding, and a
    /// potential whose force inlines into plain arithmetic or is a call on the bundle's rows
    /// ([`Potential::ROW_FORCE`]).
    pub(super) fn has_lane_loop(&self) -> bool {
        // (the lane loop tells the two kinds apart by INLINE_FORCE: a kind is one or the other)
        const { assert!(!(P::INLINE_FORCE && P::ROW_FORCE)) };
        Sh::FIXED
            && L::LANES > 1
            && std::mem::size_of::<L>() == 8 * L::LANES
            && ((P::INLINE_FORCE && self.pot.inline_force_ready()) || P::ROW_FORCE)
            && self.pairs.is_none()
    }

    /// The two-step form's steps n..e−1 between events, lane by lane (see the module); returns
    /// what [`hot`](Self::hot) returns.
    pub(super) fn lane_loop<const TRACK: bool, const PLAIN: bool, const PHI: bool>(
        &mut self,
        n: u64,
        e: u64,
    ) -> CoreResult<Option<u64>> {
        let mut kernel = LaneLoop::<L, Sh, P, TRACK, PLAIN, PHI> {
            sh: self.sh,
            pot: self.pot,
            ws: &mut self.ws,
            k: &self.k,
            w: &self.w,
            st: &mut self.st,
            ext: &mut self.ext,
            active: self.active,
            n,
            e,
        };
        Ok(crate::isa::run(&mut kernel))
    }
}

struct LaneLoop<
    'a,
    L: Real,
    Sh: Shape,
    P: Potential,
    const TRACK: bool,
    const PLAIN: bool,
    const PHI: bool,
> {
    sh: &'a Sh,
    pot: &'a P,
    /// The potential's workspace, for a force that is a call on the rows.
    ws: &'a mut P::Workspace<L>,
    k: &'a Coef<L, Sh::S<L>>,
    w: &'a Weights<L, Sh::S<L>>,
    st: &'a mut State<L, Sh>,
    ext: &'a mut Extremes<L>,
    active: LaneSet,
    n: u64,
    e: u64,
}

impl<L: Real, Sh: Shape, P: Potential, const TRACK: bool, const PLAIN: bool, const PHI: bool>
    crate::isa::Kernel for LaneLoop<'_, L, Sh, P, TRACK, PLAIN, PHI>
{
    type Output = Option<u64>;

    #[inline(always)]
    fn run(&mut self) -> Option<u64> {
        self.run_for(64)
    }

    const PLANNED: bool = true;

    fn steps(&self) -> Option<(u64, u64)> {
        Some((self.n, self.e))
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
        // With 16 vector registers (AVX2) a bundle of 8 lanes does not fit them (FPU m = 3:
        // 6 coordinates × (q, d) × 2 registers): the lanes go four at a time, one register
        // per number, as the C loop over trajectories goes.
        let group = if vector_bytes == 32 { 4 } else { L::LANES };
        let (sh, pot, k, w) = (self.sh, self.pot, self.k, self.w);
        let width = L::LANES;
        let n_coords = sh.n();
        let mut guard = L::zero();
        // The extremes in two copies that the steps alternate between, each step reading one
        // and writing the other (see `Extremes2`); the bundle's own are the first.
        let (mut spare_high, mut spare_low) = (self.ext.high, self.ext.low);
        let (high, low) = (&mut self.ext.high, &mut self.ext.low);
        let views = (
            L::as_f64s_mut(high),
            L::as_f64s_mut(low),
            L::as_f64s_mut(&mut spare_high),
            L::as_f64s_mut(&mut spare_low),
            L::as_f64s_mut(std::slice::from_mut(&mut guard)),
        );
        let (Some(high), Some(low), Some(spare_high), Some(spare_low), Some(guard_lanes)) = views
        else {
            unreachable!("a bundle of lanes without padding (checked by has_lane_loop)")
        };
        let rows = FIRST_BLOCK * width;
        let mut ext = Extremes2 {
            own: (&mut high[..rows], &mut low[..rows]),
            spare: (&mut spare_high[..rows], &mut spare_low[..rows]),
            in_spare: false,
        };
        let guard_lanes = &mut guard_lanes[..width];
        let (st, ws) = (&mut *self.st, &mut *self.ws);
        for j in self.n..self.e {
            if !P::INLINE_FORCE {
                // A force that is a call (`Potential::ROW_FORCE`): g(φq) and U(q) of every lane
                // at once, into the rows that the lanes' steps then read.
                if let Err(e) = recursion::evaluate(sh, pot, ws, k, st, TRACK, PHI, false) {
                    unreachable!("the force of a ROW_FORCE potential failed: {e}")
                }
            }
            let State { q, d, f, u, .. } = &mut *st;
            let views = (
                L::as_f64s_mut(q.get_mut()),
                L::as_f64s_mut(d.get_mut()),
                L::as_f64s(f.get()),
                L::as_f64s(std::slice::from_ref(u)),
            );
            let (Some(q), Some(d), Some(f), Some(u)) = views else {
                unreachable!("a bundle of lanes without padding (checked by has_lane_loop)")
            };
            let (q, d) = (&mut q[..n_coords * width], &mut d[..n_coords * width]);
            let called = (&f[..n_coords * width], u);
            step_lanes::<L, Sh, P, TRACK, PLAIN, PHI>(
                sh,
                pot,
                k,
                w,
                (q, d, ext.next(), guard_lanes),
                called,
                group,
            );
            if j % CHECK == 0 || j + 1 == self.e {
                // Tracked: the sticky sum of the total energies; else the positions.
                let mut bad = LaneSet::EMPTY;
                let tested: &[f64] = if TRACK { guard_lanes } else { q };
                for (t, x) in tested.iter().enumerate() {
                    bad.insert_if(t % width, !x.is_finite());
                }
                if !(bad & self.active).is_empty() {
                    ext.settle();
                    return Some(j);
                }
            }
        }
        ext.settle();
        None
    }
}

/// The running extremes of a bundle (high, low: channel c of lane b at `c * width + b`) in two
/// copies, the bundle's own and a spare, which the steps alternate between: a step reads the
/// extremes from one copy and writes the updated ones into the other.
///
/// Why: updated in place, `high = if x > high { x } else { high }` is a store of a select
/// whose other value is a load from the same address, which LLVM turns into a masked store.
/// With AVX2 that is `vmaskmovpd`, microcoded on AMD Zen 2 and 3: eight of them per group of
/// four lanes made the AVX2 lane loop 2.5× the C loop on an AMD EPYC (Zen 3), FPU m = 3,
/// energies streamed (13.7 against 5.3 ns per trajectory-step). Read from one copy and
/// written to the other, the same select is a `vmaxpd`/`vminpd` (whose operand order gives
/// exactly `if x > high { x } else { high }`) and a plain store: the same bits.
struct Extremes2<'a> {
    own: (&'a mut [f64], &'a mut [f64]),
    spare: (&'a mut [f64], &'a mut [f64]),
    /// Whether the latest extremes are in the spare copy.
    in_spare: bool,
}

/// A step's extremes: (high read, high written, low read, low written).
type ExtremesStep<'b> = (&'b [f64], &'b mut [f64], &'b [f64], &'b mut [f64]);

impl Extremes2<'_> {
    /// The copies the next step reads and writes (and flips them for the step after).
    #[inline(always)]
    fn next(&mut self) -> ExtremesStep<'_> {
        self.in_spare = !self.in_spare;
        let ((oh, ol), (sh, sl)) = (&mut self.own, &mut self.spare);
        if self.in_spare {
            (oh, sh, ol, sl)
        } else {
            (sh, oh, sl, ol)
        }
    }

    /// Leaves the latest extremes in the bundle's own copy.
    #[inline(always)]
    fn settle(&mut self) {
        if self.in_spare {
            self.own.0.copy_from_slice(self.spare.0);
            self.own.1.copy_from_slice(self.spare.1);
            self.in_spare = false;
        }
    }
}

/// A force that is a call on the bundle's rows (`Potential::ROW_FORCE`), made before the
/// lanes' steps: g(φq) (lane b of coordinate i at `i * width + b`) and U(q) per lane.
type CalledForce<'a> = (&'a [f64], &'a [f64]);

/// The bundle's rows a lane step reads and writes: q, d, the extremes (read from one copy,
/// written to the other: [`Extremes2`]), the guard.
type LaneRows<'a> = (
    &'a mut [f64],
    &'a mut [f64],
    ExtremesStep<'a>,
    &'a mut [f64],
);

/// One step of every lane of a bundle, lane by lane: each lane's numbers gathered from the
/// bundle's rows (lane b of coordinate i at `i * width + b`), its step in `f64`, its numbers
/// scattered back, its extremes and guard updated; the lanes in groups of `group` (a constant
/// of each copy), with a compiler barrier between groups so that their steps are not
/// interleaved. The rows come in as separate slices (mutable borrows, so known not to
/// overlap): the compiler vectorizes the loop over the lanes without run-time overlap tests
/// (which a loop of 8 trips is not worth to it).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn step_lanes<
    L: Real,
    Sh: Shape,
    P: Potential,
    const TRACK: bool,
    const PLAIN: bool,
    const PHI: bool,
>(
    sh: &Sh,
    pot: &P,
    k: &Coef<L, Sh::S<L>>,
    w: &Weights<L, Sh::S<L>>,
    (q, d, (high, high_out, low, low_out), guard): LaneRows<'_>,
    called: CalledForce<'_>,
    group: usize,
) {
    let width = L::LANES;
    let mut first = 0;
    while first < width {
        let last = (first + group).min(width);
        step_lane_group::<L, Sh, P, TRACK, PLAIN, PHI>(
            sh, pot, k, w, q, d, high, high_out, low, low_out, guard, called, first, last,
        );
        if last < width {
            // SAFETY: an empty instruction; it only keeps the compiler from moving memory
            // accesses across it, so the next group's loads come after this group's stores.
            unsafe { std::arch::asm!("", options(nostack, preserves_flags)) };
        }
        first = last;
    }
}

/// Lanes first..last of [`step_lanes`].
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn step_lane_group<
    L: Real,
    Sh: Shape,
    P: Potential,
    const TRACK: bool,
    const PLAIN: bool,
    const PHI: bool,
>(
    sh: &Sh,
    pot: &P,
    k: &Coef<L, Sh::S<L>>,
    w: &Weights<L, Sh::S<L>>,
    q: &mut [f64],
    d: &mut [f64],
    // (each row its own argument, so that they are known not to overlap)
    high: &[f64],
    high_out: &mut [f64],
    low: &[f64],
    low_out: &mut [f64],
    guard: &mut [f64],
    (f, u): CalledForce<'_>,
    first: usize,
    last: usize,
) {
    let width = L::LANES;
    let n_coords = sh.n();
    let obs = if TRACK {
        Observe::Energies
    } else {
        Observe::No
    };
    let mut b = first;
    while b < last {
        let kb: Coef<f64, Sh::S<f64>> = k.lane(b);
        let mut s = State::<f64, Sh>::new(sh);
        for i in 0..n_coords {
            s.q.get_mut()[i] = at(q, i * width + b);
            s.d.get_mut()[i] = at(d, i * width + b);
        }
        if P::INLINE_FORCE {
            evaluate::<Sh, P, PHI>(sh, pot, &kb, &mut s, TRACK);
        } else {
            for i in 0..n_coords {
                s.f.get_mut()[i] = at(f, i * width + b);
            }
            s.u = at(u, b);
        }
        let wb: Weights<f64, Sh::S<f64>> = w.lane(b);
        let sums = recursion::two_step_one_block(sh, &kb, &wb, &mut s, obs, PLAIN);
        for i in 0..n_coords {
            set(q, i * width + b, s.q.get()[i]);
            set(d, i * width + b, s.d.get()[i]);
        }
        if TRACK {
            let main = sums.channels(s.u, PLAIN);
            // Sticky: ±0 while every total is finite, NaN from the first that is not.
            set(guard, b, at(guard, b) * main[TOTAL]);
            for (c, &x) in main.iter().enumerate() {
                if PLAIN && c == MODIFIED {
                    // H* = H_ω: its extremes are copied from H_ω's at the end (the slot in
                    // either copy is left as it was)
                    continue;
                }
                let i = c * width + b;
                set(high_out, i, at(high, i).keep_max(x));
                set(low_out, i, at(low, i).keep_min(x));
            }
        }
        b += 1;
    }
}

/// One lane's force g(φq) into `f`, and U(q) into `u` when `with_value`: the operations of
/// [`recursion::evaluate`], through the potential's [`inline_force`](Potential::inline_force).
#[inline(always)]
pub(super) fn evaluate<Sh: Shape, P: Potential, const PHI: bool>(
    sh: &Sh,
    pot: &P,
    k: &Coef<f64, Sh::S<f64>>,
    st: &mut State<f64, Sh>,
    with_value: bool,
) {
    if PHI {
        st.u = pot.inline_force(st.q.get(), st.f.get_mut(), with_value);
    } else {
        let (q, x, phi) = (st.q.get(), st.x.get_mut(), k.phi.get());
        x[..sh.ns()].copy_from_slice(&q[..sh.ns()]);
        for i in sh.ns()..sh.n() {
            x[i] = phi[sh.coef(i)] * q[i];
        }
        pot.inline_force(st.x.get(), st.f.get_mut(), false);
        if with_value {
            // U as `value` gives it: the force pass at q, its forces thrown away.
            st.u = pot.inline_force(st.q.get(), st.q_next.get_mut(), true);
        }
    }
}

/// `x[i] = v` without a bounds test (see [`at`]): every index of the lane loop is
/// `row * width + b` with row below the rows the slice was cut to and b below the width.
#[inline(always)]
pub(super) fn set(x: &mut [f64], i: usize, v: f64) {
    debug_assert!(i < x.len());
    // SAFETY: i < x.len(), as above.
    unsafe { *x.get_unchecked_mut(i) = v }
}

//! The tight loop between events: the step, the energy sums when tracked and a sticky
//! finiteness guard, compiled for each run's constants and for the widest vectors of the CPU.

use super::bundle::{Bundle, CHECK};
use crate::coefficients::{Coef, Weights};
use crate::energy::{Extremes, PackedExtremes, PairForms, Sums, TOTAL};
use crate::error::CoreResult;
use crate::output::Form;
use crate::potential::Potential;
use crate::real::{LaneSet, Real};
use crate::recursion::{self, Observe, Riders, State};
use crate::shape::{Shape, Storage};

impl<'a, L: Real, Sh: Shape, P: Potential> Bundle<'a, L, Sh, P> {
    /// [`hot`](Self::hot) with the run's constants: form, tracking, H* = H_ω, φ ≡ 1 (each a
    /// compile-time parameter, so the tight loop tests none of them).
    pub(super) fn hot_dispatch(&mut self, n: u64, e: u64) -> CoreResult<Option<u64>> {
        let (track, plain) = (self.record.track, self.w.plain_modified);
        // "φ ≡ 1" as a compile-time variant only for compile-time shapes (registers): run-time
        // shapes read the flag in the loop. Behind `if Sh::FIXED` the other copies are never
        // instantiated, which keeps the build short.
        if Sh::FIXED && self.k.phi_is_identity {
            return match (self.form, track, plain) {
                (Form::TwoStep, true, true) => self.hot::<true, true, true, true>(n, e),
                (Form::TwoStep, true, false) => self.hot::<true, true, false, true>(n, e),
                (Form::TwoStep, false, _) => self.hot::<true, false, true, true>(n, e),
                (Form::OneStep, true, _) => self.hot_one_step::<true>(n, e),
                (Form::OneStep, false, _) => self.hot_one_step::<false>(n, e),
            };
        }
        match (self.form, track, plain) {
            (Form::TwoStep, true, true) => self.hot::<true, true, true, false>(n, e),
            (Form::TwoStep, true, false) => self.hot::<true, true, false, false>(n, e),
            (Form::TwoStep, false, _) => self.hot::<true, false, true, false>(n, e),
            (Form::OneStep, true, _) => self.hot_one_step::<true>(n, e),
            (Form::OneStep, false, _) => self.hot_one_step::<false>(n, e),
        }
    }

    /// The one-step form's tight loop: less used, so it has one general copy (H* summed, φ
    /// applied: with H* = H_ω and φ ≡ 1 these give the numbers of the special copies).
    pub(super) fn hot_one_step<const TRACK: bool>(
        &mut self,
        n: u64,
        e: u64,
    ) -> CoreResult<Option<u64>> {
        self.hot::<false, TRACK, false, false>(n, e)
    }

    /// Steps n..e−1 between events. Returns a step at or before which a running lane turned
    /// non-finite, leaving the state (and the extremes) to be restored from the checkpoint and
    /// replayed; otherwise the state is at step e. The state and the extremes are moved into
    /// locals for the loop, so that the compiler keeps them in registers; the loop runs in the
    /// copy compiled for the widest vectors this CPU has.
    pub(super) fn hot<
        const TWO_STEP: bool,
        const TRACK: bool,
        const PLAIN: bool,
        const PHI: bool,
    >(
        &mut self,
        n: u64,
        e: u64,
    ) -> CoreResult<Option<u64>> {
        if TWO_STEP
            && Sh::FIXED
            && (P::INLINE_FORCE || P::ROW_FORCE)
            && L::LANES > 1
            && self.has_lane_loop()
        {
            return self.lane_loop::<TRACK, PLAIN, PHI>(n, e);
        }
        // The inline force where there is one (compile-time shapes only: their state lives in
        // registers, which a call that may take it by reference would put in memory).
        if Sh::FIXED && P::INLINE_FORCE && self.pot.inline_force_ready() {
            return self.hot_loop::<TWO_STEP, TRACK, PLAIN, PHI, true>(n, e);
        }
        self.hot_loop::<TWO_STEP, TRACK, PLAIN, PHI, false>(n, e)
    }

    fn hot_loop<
        const TWO_STEP: bool,
        const TRACK: bool,
        const PLAIN: bool,
        const PHI: bool,
        const INLINE: bool,
    >(
        &mut self,
        n: u64,
        e: u64,
    ) -> CoreResult<Option<u64>> {
        let mut kernel = HotLoop::<L, Sh, P, TWO_STEP, TRACK, PLAIN, PHI, INLINE> {
            sh: self.sh,
            pot: self.pot,
            ws: &mut self.ws,
            k: &self.k,
            w: &self.w,
            st: std::mem::replace(&mut self.st, State::placeholder()),
            ext: std::mem::replace(&mut self.ext, Extremes::placeholder()),
            block_sums: &mut self.block_sums,
            pairs: self.pairs,
            pairs_ride: self.pairs_ride,
            axes: &mut self.axes,
            active: self.active,
            n,
            e,
        };
        let found = crate::isa::run(&mut kernel);
        self.st = kernel.st;
        self.ext = kernel.ext;
        found
    }
}

/// The tight loop of [`Bundle::hot`] on the bundle's parts.
struct HotLoop<
    'a,
    L: Real,
    Sh: Shape,
    P: Potential,
    const TWO_STEP: bool,
    const TRACK: bool,
    const PLAIN: bool,
    const PHI: bool,
    const INLINE: bool,
> {
    sh: &'a Sh,
    pot: &'a P,
    ws: &'a mut P::Workspace<L>,
    k: &'a Coef<L, Sh::S<L>>,
    w: &'a Weights<L, Sh::S<L>>,
    st: State<L, Sh>,
    ext: Extremes<L>,
    block_sums: &'a mut [L],
    pairs: Option<&'a PairForms>,
    /// [`Bundle::pairs_ride`].
    pairs_ride: bool,
    axes: &'a mut [L],
    active: LaneSet,
    n: u64,
    e: u64,
}

impl<
        L: Real,
        Sh: Shape,
        P: Potential,
        const TWO_STEP: bool,
        const TRACK: bool,
        const PLAIN: bool,
        const PHI: bool,
        const INLINE: bool,
    > crate::isa::Kernel for HotLoop<'_, L, Sh, P, TWO_STEP, TRACK, PLAIN, PHI, INLINE>
{
    type Output = CoreResult<Option<u64>>;
    const WIDE: bool = P::SPECIALIZE;
    const AVX512: bool = P::AVX512;
    // One-lane compile-time shapes too: the AVX2 copy's three-operand forms beat the baseline's
    // (FPU m = 3, no energies, TRIGINT_ISA=avx2: 7.98 -> 6.93 ns; C without AVX-512 6.9).

    #[inline(always)]
    fn run(&mut self) -> CoreResult<Option<u64>> {
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

    fn stops_early(out: &CoreResult<Option<u64>>) -> bool {
        !matches!(out, Ok(None))
    }

    #[inline(always)]
    fn run_for(&mut self, vector_bytes: usize) -> CoreResult<Option<u64>> {
        // The state and the extremes as locals of this function: in registers for small shapes.
        let mut st = std::mem::replace(&mut self.st, State::placeholder());
        let mut ext = std::mem::replace(&mut self.ext, Extremes::placeholder());
        // With 16 vector registers (AVX2 and the baseline) one trajectory's state and its
        // extremes do not fit them: the extremes go to memory at every step (off the step's
        // critical path), which leaves the registers to the state.
        let extremes_in_memory = vector_bytes < 64 && L::LANES == 1;
        let found = self.steps(&mut st, &mut ext, extremes_in_memory);
        self.st = st;
        self.ext = ext;
        found
    }
}

impl<
        L: Real,
        Sh: Shape,
        P: Potential,
        const TWO_STEP: bool,
        const TRACK: bool,
        const PLAIN: bool,
        const PHI: bool,
        const INLINE: bool,
    > HotLoop<'_, L, Sh, P, TWO_STEP, TRACK, PLAIN, PHI, INLINE>
{
    #[inline(always)]
    fn steps(
        &mut self,
        st: &mut State<L, Sh>,
        ext: &mut Extremes<L>,
        extremes_in_memory: bool,
    ) -> CoreResult<Option<u64>> {
        let (sh, pot, k, w) = (self.sh, self.pot, self.k, self.w);
        let (active, n, e) = (self.active, self.n, self.e);
        let ws = &mut *self.ws;
        let block_sums = &mut *self.block_sums;
        // Compile-time shapes have no pair forms (see `with_shape!`): a constant None there, so
        // that the observing sweep has no branch on storing p_n.
        let pairs = if Sh::FIXED { None } else { self.pairs };
        let axes = &mut *self.axes;
        // The sweep of many blocks takes the block extremes along, and the pair forms where
        // they allow it (a wave equation's momentum): one pass over the state.
        let many = !sh.single_block();
        let riding = pairs.filter(|_| many && TWO_STEP && self.pairs_ride);
        let n_blocks = sh.block_ends().len();
        // Any other pair form needs p_n itself: the two-step sweep then stores it (q is
        // advanced after).
        let obs = match (TRACK, pairs.is_some() && riding.is_none()) {
            (false, _) => Observe::No,
            (true, false) => Observe::Energies,
            (true, true) => Observe::State,
        };
        // φ ≡ 1: a constant for compile-time shapes, else the (loop-invariant) flag, so that
        // long chains skip the product φq and the second evaluation of U as well.
        let phi = PHI || (!Sh::FIXED && k.phi_is_identity);
        // Tracked runs: ±0 while every total energy so far is finite, NaN once one is not (0 × ±∞
        // is NaN, and NaN × x stays NaN): one multiplication a step.
        let mut guard = L::zero();
        // One lane on 16 vector registers: its whole-state extremes in pairs, in memory.
        let mut packed = PackedExtremes::<PLAIN>::of(ext);
        for j in n..e {
            // One trajectory of a compile-time shape with an inline force, on 16 vector
            // registers: the step is taken as the unobserved loop takes it, and (q_n, p_n) are
            // observed after it from copies, off the step's critical path (the same forms and
            // order: the same bits). The compile-time conditions come first, so that no other
            // copy of the loop compiles this branch (behind a run-time flag alone it tripled the
            // debug build of the Rust tests).
            let sums = if INLINE
                && Sh::FIXED
                && TWO_STEP
                && TRACK
                && const { L::LANES == 1 }
                && extremes_in_memory
            {
                let (q_n, d_n) = (st.q.clone(), st.d.clone());
                recursion::evaluate(sh, pot, ws, k, st, true, phi, INLINE)?;
                recursion::two_step_one_block(sh, k, w, st, Observe::No, PLAIN);
                recursion::momenta_after_step(sh, k, st.d.get(), d_n.get(), st.p.get_mut());
                recursion::sums_of_state(sh, w, q_n.get(), st.p.get(), PLAIN, block_sums)
            } else if TWO_STEP {
                recursion::evaluate(sh, pot, ws, k, st, TRACK, phi, INLINE)?;
                let riders = if TRACK && many {
                    Riders {
                        extremes: Some((
                            &mut ext.block_high[..n_blocks],
                            &mut ext.block_low[..n_blocks],
                        )),
                        pairs: riding.map(|f| (f, &mut axes[..])),
                    }
                } else {
                    Riders::none()
                };
                let s = recursion::two_step_riding(sh, k, w, st, obs, PLAIN, block_sums, riders);
                if let (true, Some(f), None) = (TRACK, pairs, riding) {
                    f.evaluate(st.q.get(), st.p.get(), axes);
                    recursion::finish_state_step(sh, st);
                }
                s
            } else {
                let s = if TRACK {
                    if let Some(f) = pairs {
                        f.evaluate(st.q.get(), st.p.get(), axes);
                    }
                    recursion::sums_of_state(sh, w, st.q.get(), st.p.get(), PLAIN, block_sums)
                } else {
                    Sums::zero()
                };
                recursion::one_step_position(sh, k, st);
                s
            };
            if TRACK {
                let main = sums.channels(st.u, PLAIN);
                guard *= main[TOTAL];
                if extremes_in_memory {
                    packed.update(&main);
                    // The extremes' address escapes: they are stored here and reloaded when
                    // next needed, rather than kept in registers across the step.
                    std::hint::black_box(&mut packed);
                } else {
                    ext.update_channels::<PLAIN>(&main);
                }
                if many && TWO_STEP {
                    // The blocks' extremes were taken by the sweep.
                    ext.update_axes(n_blocks, axes);
                } else if many {
                    ext.update_half_blocks(block_sums, axes);
                } else if pairs.is_some() {
                    ext.update_blocks(&[], axes);
                }
            }
            if !TWO_STEP {
                recursion::evaluate(sh, pot, ws, k, st, TRACK || j + 1 == e, phi, INLINE)?;
                recursion::one_step_momentum(sh, k, st);
            }
            if j % CHECK == 0 || j + 1 == e {
                let bad = if TRACK {
                    guard.nonfinite_lanes()
                } else {
                    let mut bad = LaneSet::EMPTY;
                    for x in st.q.get() {
                        bad |= x.nonfinite_lanes();
                    }
                    bad
                };
                if !(bad & active).is_empty() {
                    // Replayed from the checkpoint, extremes included.
                    finish_extremes::<L, TRACK, PLAIN>(ext, &packed, extremes_in_memory);
                    return Ok(Some(j));
                }
            }
        }
        finish_extremes::<L, TRACK, PLAIN>(ext, &packed, extremes_in_memory);
        Ok(None)
    }
}

/// The loop's extremes back in `ext` as [`Extremes::update`] at every step would have left
/// them: from memory where they were kept there, and H*'s from H_ω's where they were skipped.
#[inline(always)]
fn finish_extremes<L: Real, const TRACK: bool, const PLAIN: bool>(
    ext: &mut Extremes<L>,
    packed: &PackedExtremes<PLAIN>,
    extremes_in_memory: bool,
) {
    if extremes_in_memory {
        packed.store(ext);
    }
    if TRACK && PLAIN {
        ext.repeat_oscillatory();
    }
}

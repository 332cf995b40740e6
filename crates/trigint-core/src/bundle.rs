//! A bundle of trajectories stepped together from the first step to the last: the run loop,
//! written once. A single trajectory is a bundle of one `f64` lane; a batch is many bundles of
//! `Lanes<W>`.
//!
//! Steps between events run in a tight loop ([`Bundle::hot`]): the step, the energy sums when
//! they are tracked, and a finiteness test of the total energy. Events are the steps that need
//! more: a sample, a lane's last step, a progress report, and a check every few steps. An event
//! is a careful step: it observes the whole state, records what is asked for, and keeps that
//! observation as the last good one. When a lane turns non-finite, the bundle goes back to the
//! checkpoint at the start of the segment and replays it carefully (the same operations, so the
//! same bits) up to the first non-finite step, so the last finite state is kept exactly.
//! Lanes that have ended (completed or blown up) keep running but are masked out of every test
//! and record.
//!
//! Between steps the state holds q_n and d_n (two-step form; the force g(φq_n) is evaluated at
//! the top of step n, so it is not carried from one step to the next) or q_n, p_n and g_n
//! (one-step form, which needs g_n in two consecutive steps).

use crate::coefficients::{Coef, MethodCoefficients, Weights};
use crate::energy::{
    max_deviation, Extremes, Samples, Sums, FIRST_BLOCK, MODIFIED, OSCILLATORY, TOTAL,
};
use crate::error::CoreResult;
use crate::output::{Form, Record, Status, TrajectoryOutput};
use crate::potential::Potential;
use crate::real::{LaneSet, Real};
use crate::recursion::{self, Observe, State};
use crate::shape::{Shape, Storage};

/// Steps between finiteness tests in the tight loop: of the positions (untracked runs; a NaN or
/// an infinity never leaves the recursion, so a later test finds an earlier blow-up), or of a
/// sticky sum of the total energies (tracked runs). A test costs a branch on the step's longest
/// chain (2.3 of 12.3 ns per FPU step when done every step).
const CHECK: u64 = 64;
/// Steps between events at most: this bounds the cost of a replay.
const SEGMENT: u64 = 4096;

/// How a run reports progress and learns that it should stop.
pub struct Control<'c> {
    /// Steps between reports (also how often a stop request is noticed).
    pub every: u64,
    /// Called with the step reached; returning false stops the run ("interrupted").
    pub report: &'c mut dyn FnMut(u64) -> bool,
}

/// The state of one observed step, kept as the last good one.
struct Observed<L: Real, Sh: Shape> {
    step: u64,
    q: Sh::S<L>,
    p: Sh::S<L>,
    main: [L; FIRST_BLOCK],
    /// I_1 … I_ℓ for ℓ > 1
    blocks: Vec<L>,
}

/// One lane's bookkeeping.
struct Lane {
    n_steps: u64,
    status: Status,
    steps_done: u64,
    initial: Vec<f64>,
    /// The extremes when the lane ended.
    high: Vec<f64>,
    low: Vec<f64>,
    samples: Samples,
    message: String,
}

/// What a replay restarts from: q, d, p and the extremes at the last check.
type Checkpoint<L, Sh> = (
    <Sh as Shape>::S<L>,
    <Sh as Shape>::S<L>,
    <Sh as Shape>::S<L>,
    Extremes<L>,
);

pub struct Bundle<'a, L: Real, Sh: Shape, P: Potential> {
    sh: &'a Sh,
    pot: &'a P,
    ws: P::Workspace<L>,
    form: Form,
    record: Record,
    k: Coef<L, Sh::S<L>>,
    w: Weights<L, Sh::S<L>>,
    st: State<L, Sh>,
    checkpoint: Checkpoint<L, Sh>,
    good: Observed<L, Sh>,
    ext: Extremes<L>,
    /// Σ(p² + ω²q²) per block, when ℓ > 1
    block_sums: Vec<L>,
    lanes: Vec<Lane>,
    /// The lanes still running.
    active: LaneSet,
}

impl<'a, L: Real, Sh: Shape, P: Potential> Bundle<'a, L, Sh, P> {
    /// Up to `L::LANES` trajectories (`methods`, `q0`, `p0` and `n_steps` per lane; lanes
    /// beyond them repeat the last trajectory and are never reported). Everything is assumed
    /// validated.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        sh: &'a Sh,
        pot: &'a P,
        omega2: &[f64],
        form: Form,
        record: Record,
        methods: &[&MethodCoefficients],
        q0: &[&[f64]],
        p0: &[&[f64]],
        n_steps: &[u64],
    ) -> Self {
        let count = methods.len();
        let n_blocks = sh.block_ends().len();
        let mut st = State::<L, Sh>::new(sh);
        for (dst, rows) in [(&mut st.q, q0), (&mut st.p, p0)] {
            for (i, x) in dst.get_mut().iter_mut().enumerate() {
                for b in 0..L::LANES {
                    x.set_lane(b, rows[b.min(count - 1)][i]);
                }
            }
        }
        let z = || Sh::S::<L>::filled(sh.n(), L::zero());
        let lanes = n_steps
            .iter()
            .map(|&n| Lane {
                n_steps: n,
                status: Status::Completed,
                steps_done: 0,
                initial: vec![f64::NAN; FIRST_BLOCK + n_blocks],
                high: Vec::new(),
                low: Vec::new(),
                samples: Samples::default(),
                message: String::new(),
            })
            .collect();
        Bundle {
            sh,
            pot,
            ws: pot.workspace(),
            form,
            record,
            k: Coef::new(sh, methods),
            w: Weights::new(sh, omega2, methods),
            st,
            checkpoint: (z(), z(), z(), Extremes::new(n_blocks)),
            good: Observed {
                step: 0,
                q: z(),
                p: z(),
                main: [L::zero(); FIRST_BLOCK],
                blocks: vec![L::zero(); if n_blocks > 1 { n_blocks } else { 0 }],
            },
            ext: Extremes::new(n_blocks),
            block_sums: vec![L::zero(); n_blocks.max(1)],
            lanes,
            active: LaneSet::first(count),
        }
    }

    #[inline(always)]
    fn evaluate(&mut self, with_value: bool) -> CoreResult<()> {
        let phi = self.k.phi_is_identity;
        recursion::evaluate(
            self.sh,
            self.pot,
            &mut self.ws,
            &self.k,
            &mut self.st,
            with_value,
            phi,
        )
    }

    /// Runs every lane to its last step (or blow-up, or interruption).
    #[inline(always)]
    pub fn run(mut self, control: &mut Control) -> CoreResult<Vec<TrajectoryOutput>> {
        match self.steps(control) {
            Ok(()) => {}
            // Stopped from inside the potential: end at the last observed state.
            Err(crate::error::CoreError::Interrupted) => {
                let step = self.good.step;
                self.interrupt(step);
            }
            Err(e) => return Err(e),
        }
        Ok(self.finish())
    }

    #[inline(always)]
    fn steps(&mut self, control: &mut Control) -> CoreResult<()> {
        self.start()?;
        let mut n = 1;
        while !self.active.is_empty() {
            let e = self.next_event(n, SEGMENT, control.every);
            self.save_checkpoint();
            let detected = self.hot_dispatch(n, e)?;
            if let Some(j) = detected {
                // A lane is not finite at step j or before: replay n..=j carefully.
                self.restore_checkpoint()?;
                for i in n..=j {
                    let sums = self.observe_state()?;
                    self.careful(i, sums, false)?;
                }
                n = j + 1;
                continue;
            }
            let mut sums = self.observe_state()?;
            if e > n && !self.nonfinite(&sums).is_empty() {
                // The last good state is at n − 1, not e − 1: replay the segment carefully.
                self.restore_checkpoint()?;
                for i in n..e {
                    let s = self.observe_state()?;
                    self.careful(i, s, false)?;
                }
                sums = self.observe_state()?;
            }
            self.careful(e, sums, true)?;
            if !self.active.is_empty() && e.is_multiple_of(control.every) && !(control.report)(e) {
                self.interrupt(e);
            }
            n = e + 1;
        }
        Ok(())
    }

    /// The next step that needs a careful observation.
    fn next_event(&self, n: u64, check: u64, every: u64) -> u64 {
        let up_to_multiple = |s: u64| n.div_ceil(s) * s;
        let mut e = n.saturating_add(check - 1);
        if let Some(s) = self.record.save_every {
            e = e.min(up_to_multiple(s));
        }
        e = e.min(up_to_multiple(every.max(1)));
        for b in self.active.iter() {
            e = e.min(self.lanes[b].n_steps);
        }
        e
    }

    /// [`hot`](Self::hot) with the run's constants: form, tracking, H* = H_ω, φ ≡ 1 (each a
    /// compile-time parameter, so the tight loop tests none of them).
    fn hot_dispatch(&mut self, n: u64, e: u64) -> CoreResult<Option<u64>> {
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
    fn hot_one_step<const TRACK: bool>(&mut self, n: u64, e: u64) -> CoreResult<Option<u64>> {
        self.hot::<false, TRACK, false, false>(n, e)
    }

    /// Steps n..e−1 between events. Returns a step at or before which a running lane turned
    /// non-finite, leaving the state (and the extremes) to be restored from the checkpoint and
    /// replayed; otherwise the state is at step e. The state and the extremes are moved into
    /// locals for the loop, so that the compiler keeps them in registers; the loop runs in the
    /// copy compiled for the widest vectors this CPU has.
    fn hot<const TWO_STEP: bool, const TRACK: bool, const PLAIN: bool, const PHI: bool>(
        &mut self,
        n: u64,
        e: u64,
    ) -> CoreResult<Option<u64>> {
        let mut kernel = HotLoop::<L, Sh, P, TWO_STEP, TRACK, PLAIN, PHI> {
            sh: self.sh,
            pot: self.pot,
            ws: &mut self.ws,
            k: &self.k,
            w: &self.w,
            st: std::mem::replace(&mut self.st, State::placeholder()),
            ext: std::mem::replace(&mut self.ext, Extremes::placeholder()),
            block_sums: &mut self.block_sums,
            active: self.active,
            n,
            e,
        };
        let found = crate::isa::run(&mut kernel);
        self.st = kernel.st;
        self.ext = kernel.ext;
        found
    }

    /// ½ Σ per block: the block energies I_j in `block_sums`.
    fn half_blocks(&mut self) {
        let half = L::splat(0.5);
        for s in &mut self.block_sums {
            *s = half * *s;
        }
    }

    /// The energy sums of the current step with p_n in the state's `p` and q still at q_n
    /// (the two-step form evaluates its force here).
    fn observe_state(&mut self) -> CoreResult<Sums<L>> {
        Ok(match self.form {
            Form::TwoStep => {
                self.evaluate(true)?;
                recursion::two_step(
                    self.sh,
                    &self.k,
                    &self.w,
                    &mut self.st,
                    Observe::State,
                    self.w.plain_modified,
                    &mut self.block_sums,
                )
            }
            Form::OneStep => recursion::sums_of_state(
                self.sh,
                &self.w,
                self.st.q.get(),
                self.st.p.get(),
                self.w.plain_modified,
                &mut self.block_sums,
            ),
        })
    }

    /// Completes the step after [`observe_state`](Self::observe_state).
    fn advance_after_state(&mut self) -> CoreResult<()> {
        match self.form {
            Form::TwoStep => {
                recursion::finish_state_step(self.sh, &mut self.st);
                Ok(())
            }
            Form::OneStep => {
                recursion::one_step_position(self.sh, &self.k, &mut self.st);
                self.evaluate(true)?;
                recursion::one_step_momentum(self.sh, &self.k, &mut self.st);
                Ok(())
            }
        }
    }

    fn nonfinite(&self, sums: &Sums<L>) -> LaneSet {
        let main = sums.channels(self.st.u, self.w.plain_modified);
        main[TOTAL].nonfinite_lanes() & self.active
    }

    fn save_checkpoint(&mut self) {
        self.checkpoint.0.get_mut().copy_from_slice(self.st.q.get());
        self.checkpoint.1.get_mut().copy_from_slice(self.st.d.get());
        self.checkpoint.2.get_mut().copy_from_slice(self.st.p.get());
        self.checkpoint.3.clone_from(&self.ext);
    }

    fn restore_checkpoint(&mut self) -> CoreResult<()> {
        self.st.q.get_mut().copy_from_slice(self.checkpoint.0.get());
        self.st.d.get_mut().copy_from_slice(self.checkpoint.1.get());
        self.st.p.get_mut().copy_from_slice(self.checkpoint.2.get());
        self.ext.clone_from(&self.checkpoint.3);
        match self.form {
            Form::TwoStep => Ok(()),
            Form::OneStep => self.evaluate(true),
        }
    }

    /// Step 0: observe (q_0, p_0) and start the recursion.
    fn start(&mut self) -> CoreResult<()> {
        self.evaluate(true)?;
        let sums = recursion::sums_of_state(
            self.sh,
            &self.w,
            self.st.q.get(),
            self.st.p.get(),
            self.w.plain_modified,
            &mut self.block_sums,
        );
        let (main, blocks) = self.channels(&sums);
        for b in self.active.iter() {
            self.lanes[b].initial = self.row(&main, &blocks, b);
        }
        self.take_observation(0, &main, &blocks, true);
        match self.form {
            Form::TwoStep => {
                recursion::two_step_start(self.sh, &self.k, &mut self.st);
                Ok(())
            }
            Form::OneStep => self.advance_after_state(),
        }
    }

    /// The main channels and (ℓ > 1) the block energies of the current sums.
    fn channels(&mut self, sums: &Sums<L>) -> ([L; FIRST_BLOCK], Vec<L>) {
        let main = sums.channels(self.st.u, self.w.plain_modified);
        let blocks = if self.sh.single_block() {
            Vec::new()
        } else {
            self.half_blocks();
            self.block_sums.clone()
        };
        (main, blocks)
    }

    /// A careful step: observe step i from `sums`, handle blow-ups, record (events), advance.
    fn careful(&mut self, i: u64, sums: Sums<L>, event: bool) -> CoreResult<()> {
        let (main, blocks) = self.channels(&sums);
        self.take_observation(i, &main, &blocks, event);
        self.advance_after_state()
    }

    /// What a careful step does with its observation (the state at step i is in q and p).
    fn take_observation(&mut self, i: u64, main: &[L; FIRST_BLOCK], blocks: &[L], event: bool) {
        let bad = main[TOTAL].nonfinite_lanes() & self.active;
        for b in bad.iter() {
            self.blow_up(b, i);
        }
        if self.record.track {
            self.update_extremes(main, blocks, self.active);
        }
        if event {
            let sampling = i == 0 || self.record.save_every.is_some_and(|s| i.is_multiple_of(s));
            for b in self.active.iter() {
                let ends = self.lanes[b].n_steps == i;
                if ends || sampling {
                    self.sample(b, i, main, blocks);
                }
                if ends {
                    self.end_lane(b, Status::Completed, i);
                    self.lanes[b].message = format!("completed {i} steps");
                }
            }
        }
        self.good.step = i;
        self.good.q.get_mut().copy_from_slice(self.st.q.get());
        self.good.p.get_mut().copy_from_slice(self.st.p.get());
        self.good.main = *main;
        self.good.blocks.clone_from_slice(blocks);
    }

    /// Running extremes of the lanes in `mask` (all lanes at once when the mask is full).
    fn update_extremes(&mut self, main: &[L; FIRST_BLOCK], blocks: &[L], mask: LaneSet) {
        if mask == LaneSet::first(L::LANES) {
            self.ext.update(main, false);
            self.ext.update_blocks(blocks);
            return;
        }
        for b in mask.iter() {
            let ext = &mut self.ext;
            for c in 0..FIRST_BLOCK {
                let e = main[c].lane(b);
                let (hi, lo) = (ext.high[c].lane(b), ext.low[c].lane(b));
                ext.high[c].set_lane(b, hi.keep_max(e));
                ext.low[c].set_lane(b, lo.keep_min(e));
            }
            for (j, x) in blocks.iter().enumerate() {
                let e = x.lane(b);
                let (hi, lo) = (ext.block_high[j].lane(b), ext.block_low[j].lane(b));
                ext.block_high[j].set_lane(b, hi.keep_max(e));
                ext.block_low[j].set_lane(b, lo.keep_min(e));
            }
        }
    }

    /// The energy row of lane b in channel order.
    fn row(&self, main: &[L; FIRST_BLOCK], blocks: &[L], b: usize) -> Vec<f64> {
        let mut r: Vec<f64> = main.iter().map(|x| x.lane(b)).collect();
        if self.sh.single_block() {
            if !self.sh.block_ends().is_empty() {
                r.push(main[OSCILLATORY].lane(b));
            }
        } else {
            r.extend(blocks.iter().map(|x| x.lane(b)));
        }
        r
    }

    /// Keeps lane b's state at `step` (from q and p as given) unless it is kept already or the
    /// run keeps no samples.
    fn keep(&mut self, b: usize, step: u64, q: &[L], p: &[L], row: Vec<f64>) {
        let s = &mut self.lanes[b].samples;
        if self.record.save_every.is_none() || s.steps.last() == Some(&step) {
            return;
        }
        s.steps.push(step);
        s.q.extend(q.iter().map(|x| x.lane(b)));
        s.p.extend(p.iter().map(|x| x.lane(b)));
        s.energies.extend(row);
    }

    fn sample(&mut self, b: usize, step: u64, main: &[L; FIRST_BLOCK], blocks: &[L]) {
        let row = self.row(main, blocks, b);
        let (q, p) = (self.st.q.clone(), self.st.p.clone());
        self.keep(b, step, q.get(), p.get(), row);
    }

    /// Keeps lane b's last good state.
    fn keep_good(&mut self, b: usize) {
        let row = self.row(&self.good.main, &self.good.blocks, b);
        let (q, p) = (self.good.q.clone(), self.good.p.clone());
        self.keep(b, self.good.step, q.get(), p.get(), row);
    }

    /// Lane b is not finite at step i: it ends at step i − 1, whose state is kept.
    fn blow_up(&mut self, b: usize, i: u64) {
        if i == 0 {
            self.end_lane(b, Status::BlowUp, 0);
            self.lanes[b].message = format!(
                "the potential is not finite at the initial state (U(q0) = {}); nothing was \
                 integrated",
                self.st.u.lane(b)
            );
            return;
        }
        let good = self.good.step;
        self.keep_good(b);
        self.end_lane(b, Status::BlowUp, good);
        self.lanes[b].message = format!(
            "the solution blew up: the state at step {i} is not finite; kept the samples up to \
             step {good}, the last finite state"
        );
    }

    /// Freezes lane b's extremes and takes it out of the running.
    fn end_lane(&mut self, b: usize, status: Status, steps_done: u64) {
        let n_blocks = self.sh.block_ends().len();
        let (mut high, mut low) = self.ext.lane(b, n_blocks);
        if self.w.plain_modified {
            // H* is H_ω: its extremes were not kept separately.
            high[MODIFIED] = high[OSCILLATORY];
            low[MODIFIED] = low[OSCILLATORY];
        }
        let lane = &mut self.lanes[b];
        lane.status = status;
        lane.steps_done = steps_done;
        lane.high = high;
        lane.low = low;
        self.active.remove(b);
    }

    /// A stop request at step e (observed, state already advanced): the running lanes end
    /// there, their last observed state kept.
    fn interrupt(&mut self, e: u64) {
        for b in self.active.iter() {
            self.keep_good(b);
            let n = self.lanes[b].n_steps;
            self.end_lane(b, Status::Interrupted, e);
            self.lanes[b].message = format!(
                "interrupted after step {e} of {n}; kept the samples up to there, the state at \
                 step {e} included"
            );
        }
    }

    fn finish(self) -> Vec<TrajectoryOutput> {
        let track = self.record.track;
        self.lanes
            .into_iter()
            .map(|lane| TrajectoryOutput {
                status: lane.status,
                steps_done: lane.steps_done,
                max_deviation: if track && !lane.high.is_empty() {
                    max_deviation(&lane.initial, &lane.high, &lane.low)
                } else {
                    vec![f64::NAN; lane.initial.len()]
                },
                initial_energies: lane.initial,
                samples: lane.samples,
                message: lane.message,
            })
            .collect()
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
> {
    sh: &'a Sh,
    pot: &'a P,
    ws: &'a mut P::Workspace<L>,
    k: &'a Coef<L, Sh::S<L>>,
    w: &'a Weights<L, Sh::S<L>>,
    st: State<L, Sh>,
    ext: Extremes<L>,
    block_sums: &'a mut [L],
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
    > crate::isa::Kernel for HotLoop<'_, L, Sh, P, TWO_STEP, TRACK, PLAIN, PHI>
{
    type Output = CoreResult<Option<u64>>;
    const WIDE: bool = P::SPECIALIZE;
    const AVX2: bool = !(Sh::FIXED && L::LANES == 1);

    #[inline(always)]
    fn run(&mut self) -> CoreResult<Option<u64>> {
        // The state and the extremes as locals of this function: in registers for small shapes.
        let mut st = std::mem::replace(&mut self.st, State::placeholder());
        let mut ext = std::mem::replace(&mut self.ext, Extremes::placeholder());
        let found = self.steps(&mut st, &mut ext);
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
    > HotLoop<'_, L, Sh, P, TWO_STEP, TRACK, PLAIN, PHI>
{
    #[inline(always)]
    fn steps(&mut self, st: &mut State<L, Sh>, ext: &mut Extremes<L>) -> CoreResult<Option<u64>> {
        let (sh, pot, k, w) = (self.sh, self.pot, self.k, self.w);
        let (active, n, e) = (self.active, self.n, self.e);
        let ws = &mut *self.ws;
        let block_sums = &mut *self.block_sums;
        let obs = if TRACK {
            Observe::Energies
        } else {
            Observe::No
        };
        // φ ≡ 1: a constant for compile-time shapes, else the (loop-invariant) flag, so that
        // long chains skip the product φq and the second evaluation of U as well.
        let phi = PHI || (!Sh::FIXED && k.phi_is_identity);
        // Tracked runs: 0 while every total energy so far is finite, NaN once one is not.
        let mut guard = L::zero();
        let zero = L::zero();
        for j in n..e {
            let sums = if TWO_STEP {
                recursion::evaluate(sh, pot, ws, k, st, TRACK, phi)?;
                recursion::two_step(sh, k, w, st, obs, PLAIN, block_sums)
            } else {
                let s = if TRACK {
                    recursion::sums_of_state(sh, w, st.q.get(), st.p.get(), PLAIN, block_sums)
                } else {
                    Sums::zero()
                };
                recursion::one_step_position(sh, k, st);
                s
            };
            if TRACK {
                let main = sums.channels(st.u, PLAIN);
                guard += main[TOTAL] * zero;
                ext.update(&main, PLAIN);
                if !sh.single_block() {
                    let half = L::splat(0.5);
                    for s in block_sums.iter_mut() {
                        *s = half * *s;
                    }
                    ext.update_blocks(block_sums);
                }
            }
            if !TWO_STEP {
                recursion::evaluate(sh, pot, ws, k, st, TRACK || j + 1 == e, phi)?;
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
                    return Ok(Some(j));
                }
            }
        }
        Ok(None)
    }
}

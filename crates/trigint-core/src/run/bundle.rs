//! A bundle of trajectories stepped together by the recursion: the [`Stepper`] of the
//! two-step and one-step forms. A single trajectory is a bundle of one `f64` lane; a batch is
//! many bundles of `Lanes<W>`. The run loop is [`drive`](super::drive)'s.
//!
//! Steps between events run in a tight loop ([`Bundle::hot`]): the step, the energy sums when
//! they are tracked, and a finiteness test of the total energy every [`CHECK`] steps. An event
//! is a careful step: it observes the whole state, records what is asked for, and keeps that
//! observation as the last good one. Lanes that have ended (completed or blown up) keep running
//! but are masked out of every test and record.
//!
//! Between steps the state holds q_n and d_n (two-step form; the force g(φq_n) is evaluated at
//! the top of step n, so it is not carried from one step to the next) or q_n, p_n and g_n
//! (one-step form, which needs g_n in two consecutive steps).

use std::sync::Arc;

use crate::channels::channel_count;
use crate::coefficients::{Coef, MethodCoefficients, Weights};
use crate::energy::{with_axes_room, Extremes, PairForms, Samples, Sums, FIRST_BLOCK, TOTAL};
use crate::error::CoreResult;
use crate::output::{Form, Record, Status, TrajectoryOutput};
use crate::potential::Potential;
use crate::real::{LaneSet, Real};
use crate::recursion::{self, Observe, State};
use crate::shape::{Shape, Storage};

use super::drive::{self, Control, Stepper};

/// Steps between finiteness tests in the tight loop: of the positions (untracked runs; a NaN or
/// an infinity never leaves the recursion, so a later test finds an earlier blow-up), or of a
/// sticky sum of the total energies (tracked runs). A test costs a branch on the step's longest
/// chain (2.3 of 12.3 ns per FPU step when done every step).
pub(super) const CHECK: u64 = 64;
/// The state of one observed step, kept as the last good one.
pub(super) struct Observed<L: Real, Sh: Shape> {
    pub(super) step: u64,
    pub(super) q: Sh::S<L>,
    pub(super) p: Sh::S<L>,
    pub(super) main: [L; FIRST_BLOCK],
    /// I_1 … I_ℓ for ℓ > 1, then the per-axis channels
    pub(super) blocks: Vec<L>,
}

/// One lane's bookkeeping.
pub(crate) struct Lane {
    pub(crate) n_steps: u64,
    pub(crate) status: Status,
    pub(crate) steps_done: u64,
    pub(crate) initial: Vec<f64>,
    /// The extremes when the lane ended.
    pub(crate) high: Vec<f64>,
    pub(crate) low: Vec<f64>,
    pub(crate) samples: Samples,
    pub(crate) message: String,
}

impl Lane {
    /// A lane to run for `n_steps` steps with `channels` energy channels.
    pub(crate) fn new(n_steps: u64, channels: usize) -> Self {
        Lane {
            n_steps,
            status: Status::Completed,
            steps_done: 0,
            initial: with_axes_room(channels, f64::NAN),
            high: Vec::new(),
            low: Vec::new(),
            samples: Samples::default(),
            message: String::new(),
        }
    }
}

/// What a replay restarts from: q, d, p and the extremes at the last check.
pub(super) type Checkpoint<L, Sh> = (
    <Sh as Shape>::S<L>,
    <Sh as Shape>::S<L>,
    <Sh as Shape>::S<L>,
    Extremes<L>,
);

pub struct Bundle<'a, L: Real, Sh: Shape, P: Potential> {
    pub(super) sh: &'a Sh,
    pub(super) pot: &'a P,
    pub(super) ws: P::Workspace<L>,
    pub(super) form: Form,
    pub(super) record: Record,
    /// The kernels' rows: made for this run, or kept by a [`PreparedMethod`](crate::prepared::PreparedMethod).
    pub(super) k: Arc<Coef<L, Sh::S<L>>>,
    pub(super) w: Arc<Weights<L, Sh::S<L>>>,
    pub(super) st: State<L, Sh>,
    pub(super) checkpoint: Checkpoint<L, Sh>,
    pub(super) good: Observed<L, Sh>,
    pub(super) ext: Extremes<L>,
    /// Σ(p² + ω²q²) per block, when ℓ > 1
    pub(super) block_sums: Vec<L>,
    /// The layout's pair forms (a momentum), streamed as the per-axis channels into `axes`.
    pub(super) pairs: Option<&'a PairForms>,
    /// Whether the pair forms ride along the sweep of many blocks ([`PairForms::rides_along`],
    /// a walk over every block and pair: decided once, not at every piece of a run).
    pub(super) pairs_ride: bool,
    pub(super) axes: Vec<L>,
    pub(super) lanes: Vec<Lane>,
    /// The lanes still running.
    pub(super) active: LaneSet,
    /// Keep a sample's q in the user's coordinates where the potential's evaluation made them
    /// ([`Bundle::with_q_from_grid`]).
    pub(super) q_from_grid: bool,
}

/// A bundle's kernel rows and energy weights, made for it or kept by a prepared method.
pub type Rows<L, Sh> = (
    Arc<Coef<L, <Sh as Shape>::S<L>>>,
    Arc<Weights<L, <Sh as Shape>::S<L>>>,
);

/// The kernel rows and energy weights of `methods` on a layout's frequencies ω².
pub fn rows<L: Real, Sh: Shape>(
    sh: &Sh,
    omega2: &[f64],
    methods: &[&MethodCoefficients],
) -> Rows<L, Sh> {
    (
        Arc::new(Coef::new(sh, methods)),
        Arc::new(Weights::new(sh, omega2, methods)),
    )
}

impl<'a, L: Real, Sh: Shape, P: Potential> Bundle<'a, L, Sh, P> {
    /// Up to `L::LANES` trajectories (`methods`, `q0`, `p0` and `n_steps` per lane; lanes
    /// beyond them repeat the last trajectory and are never reported), with their kernel rows
    /// and energy weights ([`rows`], or kept ones). Everything is assumed validated.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        sh: &'a Sh,
        pot: &'a P,
        form: Form,
        record: Record,
        (k, w): Rows<L, Sh>,
        methods: &[&MethodCoefficients],
        q0: &[&[f64]],
        p0: &[&[f64]],
        n_steps: &[u64],
    ) -> Self {
        let count = methods.len();
        let n_blocks = sh.block_ends().len();
        let st = State::<L, Sh>::for_steps(
            sh,
            form == Form::OneStep,
            k.phi_is_identity,
            (&q0[..count], &p0[..count]),
        );
        let lanes = n_steps
            .iter()
            .map(|&n| Lane::new(n, FIRST_BLOCK + n_blocks))
            .collect();
        Bundle {
            sh,
            pot,
            ws: pot.workspace(),
            form,
            record,
            k,
            w,
            st,
            // (filled at the first check: zeros written here would only be overwritten)
            checkpoint: (
                Sh::S::<L>::placeholder(),
                Sh::S::<L>::placeholder(),
                Sh::S::<L>::placeholder(),
                Extremes::placeholder(),
            ),
            // (filled when first kept: a short run that samples every step it observes never
            // reads them, and zeros written here would only be overwritten)
            good: Observed {
                step: 0,
                q: Sh::S::<L>::placeholder(),
                p: Sh::S::<L>::placeholder(),
                main: [L::zero(); FIRST_BLOCK],
                blocks: with_axes_room(if n_blocks > 1 { n_blocks } else { 0 }, L::zero()),
            },
            ext: Extremes::new(n_blocks, 0),
            block_sums: vec![L::zero(); n_blocks.max(1)],
            pairs: None,
            pairs_ride: false,
            axes: Vec::new(),
            lanes,
            active: LaneSet::first(count),
            q_from_grid: false,
        }
    }

    /// Keeps each sample's q in the user's coordinates where the potential's force evaluation
    /// at that step made them ([`Potential::evaluated_in_user_coordinates`]: a wave's grid
    /// values, one trajectory, φ = 1), marked in [`Samples::q_in_user`](crate::energy::Samples::q_in_user);
    /// the caller transforms the other rows back. The same bits as transforming them all.
    pub fn with_q_from_grid(mut self, on: bool) -> Self {
        self.q_from_grid = on;
        self
    }

    /// Streams the layout's pair forms (if any) as the per-axis channels.
    pub fn with_pair_forms(mut self, pairs: Option<&'a PairForms>) -> Self {
        let Some(f) = pairs else {
            return self;
        };
        let (n_blocks, axes) = (self.sh.block_ends().len(), f.axes());
        self.pairs = pairs;
        self.pairs_ride = f.rides_along(self.sh.ns(), self.sh.block_ends());
        self.axes = vec![L::zero(); axes];
        // The per-axis channels after the blocks' (grown, not made again: a 2¹⁶-point wave
        // has 32 769 blocks).
        let several = if n_blocks > 1 { n_blocks } else { 0 } + axes;
        let (high, low) = (&mut self.ext.block_high, &mut self.ext.block_low);
        high.resize(several, L::splat(f64::NEG_INFINITY));
        low.resize(several, L::splat(f64::INFINITY));
        self.good.blocks.resize(several, L::zero());
        for lane in &mut self.lanes {
            lane.initial.resize(channel_count(n_blocks, axes), f64::NAN);
        }
        self
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
            false,
        )
    }

    /// Runs every lane to its last step (or blow-up, or interruption).
    #[inline(always)]
    pub fn run(mut self, control: &mut Control) -> CoreResult<Vec<TrajectoryOutput>> {
        drive::run(&mut self, control)
    }

    /// ½ Σ per block: the block energies I_j in `block_sums`.
    pub(super) fn half_blocks(&mut self) {
        let half = L::splat(0.5);
        for s in &mut self.block_sums {
            *s = half * *s;
        }
    }

    /// Completes the step after [`Stepper::observe`].
    pub(super) fn advance_after_state(&mut self) -> CoreResult<()> {
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

    /// The main channels, (ℓ > 1) the block energies of the current sums and the per-axis
    /// channels of the state (q_n in `q`, p_n in `p`).
    pub(super) fn channels(&mut self, sums: &Sums<L>) -> ([L; FIRST_BLOCK], Vec<L>) {
        let main = sums.channels(self.st.u, self.w.plain_modified);
        let extra = if self.pairs.is_some() {
            self.axes.len()
        } else {
            0
        };
        let mut blocks = if self.sh.single_block() {
            Vec::with_capacity(extra)
        } else {
            self.half_blocks();
            // (sized for the axes' channels too: growing it copied the block energies again)
            let mut b = Vec::with_capacity(self.block_sums.len() + extra);
            b.extend_from_slice(&self.block_sums);
            b
        };
        if let Some(f) = self.pairs {
            f.evaluate(self.st.q.get(), self.st.p.get(), &mut self.axes);
            blocks.extend_from_slice(&self.axes);
        }
        (main, blocks)
    }
}

impl<L: Real, Sh: Shape, P: Potential> Stepper for Bundle<'_, L, Sh, P> {
    type Observation = Sums<L>;
    type Output = Vec<TrajectoryOutput>;
    const SEGMENT: u64 = 4096;

    fn active(&self) -> LaneSet {
        self.active
    }

    fn record(&self) -> Record {
        self.record
    }

    fn n_steps(&self, b: usize) -> u64 {
        self.lanes[b].n_steps
    }

    #[inline(always)]
    fn hot(&mut self, n: u64, e: u64) -> CoreResult<Option<u64>> {
        self.hot_dispatch(n, e)
    }

    /// The energy sums of the current step with p_n in the state's `p` and q still at q_n
    /// (the two-step form evaluates its force here).
    fn observe(&mut self) -> CoreResult<Sums<L>> {
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

    fn nonfinite(&self, sums: &Sums<L>) -> LaneSet {
        let main = sums.channels(self.st.u, self.w.plain_modified);
        main[TOTAL].nonfinite_lanes() & self.active
    }

    /// The two-step form's state is (q_n, d_n): its p_n is computed by the observation of step
    /// n, which a replay's careful step makes before reading it, so p is kept for the one-step
    /// form only (on a 2¹⁶-point wave, 512 KiB not copied at every event).
    fn save_checkpoint(&mut self) {
        self.checkpoint.0.clone_from(&self.st.q);
        self.checkpoint.1.clone_from(&self.st.d);
        if self.form == Form::OneStep {
            self.checkpoint.2.clone_from(&self.st.p);
        }
        self.checkpoint.3.clone_from(&self.ext);
    }

    fn restore_checkpoint(&mut self) -> CoreResult<()> {
        self.st.q.get_mut().copy_from_slice(self.checkpoint.0.get());
        self.st.d.get_mut().copy_from_slice(self.checkpoint.1.get());
        if self.form == Form::OneStep {
            self.st.p.get_mut().copy_from_slice(self.checkpoint.2.get());
        }
        self.ext.clone_from(&self.checkpoint.3);
        match self.form {
            Form::TwoStep => Ok(()),
            Form::OneStep => self.evaluate(true),
        }
    }

    /// Step 0: observe (q_0, p_0) and start the recursion.
    fn start(&mut self) -> CoreResult<()> {
        self.evaluate(true)?;
        // (the sweeps of step 0 in the widest copy: compiled for the baseline alone, they were
        // a tenth of a 2-step call's time on a 2¹⁶-point wave)
        let (sh, w, plain) = (self.sh, &self.w, self.w.plain_modified);
        let (q, p, blocks) = (self.st.q.get(), self.st.p.get(), &mut self.block_sums);
        let sums = crate::isa::wide(|| recursion::sums_of_state(sh, w, q, p, plain, blocks));
        let (main, blocks) = self.channels(&sums);
        for b in self.active.iter() {
            self.lanes[b].initial = self.row(&main, &blocks, b);
        }
        self.take_observation(0, &main, &blocks, true);
        match self.form {
            Form::TwoStep => {
                let (sh, k, st) = (self.sh, &self.k, &mut self.st);
                crate::isa::wide(|| recursion::two_step_start(sh, k, st));
                Ok(())
            }
            Form::OneStep => self.advance_after_state(),
        }
    }

    /// A careful step: observe step i from `sums`, handle blow-ups, record (events), advance.
    fn careful(&mut self, i: u64, sums: Sums<L>, event: bool) -> CoreResult<()> {
        let (main, blocks) = self.channels(&sums);
        self.take_observation(i, &main, &blocks, event);
        self.advance_after_state()
    }

    fn interrupt_at_last_observation(&mut self) {
        let step = self.good.step;
        self.end_interrupted(step);
    }

    fn interrupt(&mut self, e: u64) {
        self.end_interrupted(e);
    }

    fn finish(&mut self) -> Vec<TrajectoryOutput> {
        self.outputs()
    }
}

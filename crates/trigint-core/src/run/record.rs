//! What a careful step records: blow-ups, running extremes, samples, a lane's end, and the
//! outputs of a finished bundle.
//!
//! The bookkeeping is written as functions of the lane type alone ([`LaneBook`]): it runs at events,
//! not in the tight loop, so compiling it once per potential kind and shape (as methods of the
//! generic [`Bundle`] would be) bought no speed and cost build time. The bundle's methods here
//! only hand it their parts.

use super::bundle::{Bundle, Lane};
use crate::energy::{max_deviation, Extremes, FIRST_BLOCK, MODIFIED, OSCILLATORY, TOTAL};
use crate::output::{Record, Status, TrajectoryOutput};
use crate::potential::Potential;
use crate::real::{LaneSet, Real};
use crate::shape::{Shape, Storage};

/// The lanes' bookkeeping and the facts about the run it needs.
pub(crate) struct LaneBook<'a, L: Real> {
    pub lanes: &'a mut [Lane],
    pub ext: &'a mut Extremes<L>,
    pub active: &'a mut LaneSet,
    pub record: Record,
    /// ℓ, and whether the oscillatory coordinates form one block
    pub n_blocks: usize,
    pub single_block: bool,
    /// H* is H_ω: its extremes are not kept separately
    pub plain_modified: bool,
}

/// The last observed (good) state of a bundle, as lane values: the state and channels of
/// `step`, except where every running lane already keeps a sample of `step` or keeps none
/// (then they are older and never read: [`LaneBook::keep`] returns first).
pub(crate) struct Good<'a, L> {
    pub step: u64,
    pub q: &'a [L],
    pub p: &'a [L],
    pub main: &'a [L; FIRST_BLOCK],
    pub blocks: &'a [L],
}

impl<L: Real> LaneBook<'_, L> {
    /// Running extremes of the lanes in `mask` (all lanes at once when the mask is full).
    #[inline(never)]
    pub fn update_extremes(&mut self, main: &[L; FIRST_BLOCK], blocks: &[L], mask: LaneSet) {
        let ext = &mut *self.ext;
        if mask == LaneSet::first(L::LANES) {
            ext.update(main);
            ext.update_blocks(blocks, &[]);
            return;
        }
        for b in mask.iter() {
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

    /// The energy row of lane b in channel order (`blocks`: I_1 … I_ℓ for ℓ > 1, then the
    /// per-axis channels).
    pub fn row(&self, main: &[L; FIRST_BLOCK], blocks: &[L], b: usize) -> Vec<f64> {
        let mut r: Vec<f64> = main.iter().map(|x| x.lane(b)).collect();
        if self.single_block && self.n_blocks > 0 {
            r.push(main[OSCILLATORY].lane(b));
        }
        r.extend(blocks.iter().map(|x| x.lane(b)));
        r
    }

    /// Keeps lane b's state at `step` (from q and p as given; q from `q_user`, in the user's
    /// coordinates, where given for a bundle of one lane) unless it is kept already or the run
    /// keeps no samples.
    #[inline(never)]
    #[allow(clippy::too_many_arguments)]
    pub fn keep(
        &mut self,
        b: usize,
        step: u64,
        q: &[L],
        p: &[L],
        q_user: Option<&[f64]>,
        row: Vec<f64>,
    ) {
        let lane = &mut self.lanes[b];
        let s = &mut lane.samples;
        let Some(every) = self.record.save_every else {
            return;
        };
        if s.steps.last() == Some(&step) {
            return;
        }
        if s.steps.is_empty() {
            // Room for the samples of a short run (the first, every `every`-th, the last; at
            // most 4: beyond, doubling makes the copies cheap), so that a call of a few steps
            // does not copy them as they grow (1 MiB per growth at 2^16 coordinates).
            let k = (lane.n_steps / every.max(1)).saturating_add(2).min(4) as usize;
            s.steps.reserve_exact(k);
            s.q_in_user.reserve_exact(k);
            s.q.reserve_exact(k * q.len());
            s.p.reserve_exact(k * p.len());
            s.energies.reserve_exact(k * row.len());
        }
        s.steps.push(step);
        let q_user = q_user.filter(|u| L::LANES == 1 && u.len() == q.len());
        match q_user {
            Some(u) => s.q.extend_from_slice(u),
            None => s.q.extend(q.iter().map(|x| x.lane(b))),
        }
        s.q_in_user.push(q_user.is_some());
        s.p.extend(p.iter().map(|x| x.lane(b)));
        s.energies.extend(row);
    }

    /// Keeps lane b's last good state.
    pub fn keep_good(&mut self, b: usize, good: &Good<'_, L>) {
        let row = self.row(good.main, good.blocks, b);
        self.keep(b, good.step, good.q, good.p, None, row);
    }

    /// Freezes lane b's extremes and takes it out of the running.
    #[inline(never)]
    pub fn end_lane(&mut self, b: usize, status: Status, steps_done: u64, message: String) {
        let (mut high, mut low) = self.ext.lane(b, self.n_blocks);
        if self.plain_modified {
            // H* is H_ω: its extremes are H_ω's (the lane loop does not take them).
            high[MODIFIED] = high[OSCILLATORY];
            low[MODIFIED] = low[OSCILLATORY];
        }
        let lane = &mut self.lanes[b];
        lane.status = status;
        lane.steps_done = steps_done;
        lane.high = high;
        lane.low = low;
        lane.message = message;
        self.active.remove(b);
    }

    /// Lane b is not finite at step i: it ends at step i − 1, whose state is kept.
    #[inline(never)]
    pub fn blow_up(&mut self, b: usize, i: u64, u: L, good: &Good<'_, L>) {
        if i == 0 {
            let message = format!(
                "the potential is not finite at the initial state (U(q0) = {}); nothing was \
                 integrated",
                u.lane(b)
            );
            self.end_lane(b, Status::BlowUp, 0, message);
            return;
        }
        self.keep_good(b, good);
        let message = format!(
            "the solution blew up: the state at step {i} is not finite; kept the samples up to \
             step {}, the last finite state",
            good.step
        );
        self.end_lane(b, Status::BlowUp, good.step, message);
    }

    /// The running lanes cannot be stepped past their last observed state (a stepper's own
    /// limit, such as a Lanczos product that did not converge): they end there, as blow-ups,
    /// their last observed state kept, with the stepper's reason.
    #[inline(never)]
    pub fn cannot_step(&mut self, message: &str, good: &Good<'_, L>) {
        for b in self.active.iter() {
            self.keep_good(b, good);
            self.end_lane(b, Status::BlowUp, good.step, message.to_string());
        }
    }

    /// A stop request at step e (observed, state already advanced): the running lanes end
    /// there, their last observed state kept.
    #[inline(never)]
    pub fn interrupt(&mut self, e: u64, good: &Good<'_, L>) {
        for b in self.active.iter() {
            self.keep_good(b, good);
            let n = self.lanes[b].n_steps;
            let message = format!(
                "interrupted after step {e} of {n}; kept the samples up to there, the state at \
                 step {e} included"
            );
            self.end_lane(b, Status::Interrupted, e, message);
        }
    }

    /// What a careful step does with its observation of step i (state q, p; U in `u`; q in the
    /// user's coordinates in `q_user`, where the potential's evaluation made them): lanes not
    /// finite blow up, extremes, samples at events, lanes that end there.
    #[inline(never)]
    #[allow(clippy::too_many_arguments)]
    pub fn observe(
        &mut self,
        i: u64,
        (q, p, u): (&[L], &[L], L),
        q_user: Option<&[f64]>,
        main: &[L; FIRST_BLOCK],
        blocks: &[L],
        event: bool,
        good: &Good<'_, L>,
    ) {
        let bad = main[TOTAL].nonfinite_lanes() & *self.active;
        for b in bad.iter() {
            self.blow_up(b, i, u, good);
        }
        if self.record.track {
            let active = *self.active;
            self.update_extremes(main, blocks, active);
        }
        if event {
            let sampling = i == 0 || self.record.save_every.is_some_and(|s| i.is_multiple_of(s));
            for b in self.active.iter() {
                let ends = self.lanes[b].n_steps == i;
                if ends || sampling {
                    let row = self.row(main, blocks, b);
                    self.keep(b, i, q, p, q_user, row);
                }
                if ends {
                    self.end_lane(b, Status::Completed, i, format!("completed {i} steps"));
                }
            }
        }
    }
}

/// The outputs of a finished bundle's lanes.
pub(crate) fn finish(lanes: Vec<Lane>, track: bool) -> Vec<TrajectoryOutput> {
    lanes
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

/// `(LaneBook, Good)` of a bundle, borrowing its fields one by one.
macro_rules! parts {
    ($b:expr) => {{
        let lanes = LaneBook {
            lanes: &mut $b.lanes,
            ext: &mut $b.ext,
            active: &mut $b.active,
            record: $b.record,
            n_blocks: $b.sh.block_ends().len(),
            single_block: $b.sh.single_block(),
            plain_modified: $b.w.plain_modified,
        };
        let good = Good {
            step: $b.good.step,
            q: $b.good.q.get(),
            p: $b.good.p.get(),
            main: &$b.good.main,
            blocks: &$b.good.blocks,
        };
        (lanes, good)
    }};
}

impl<'a, L: Real, Sh: Shape, P: Potential> Bundle<'a, L, Sh, P> {
    /// The lanes' bookkeeping and the last good state, borrowed field by field from the bundle
    /// (so that the state can be borrowed beside them).
    fn parts(&mut self) -> (LaneBook<'_, L>, Good<'_, L>) {
        parts!(self)
    }

    /// What a careful step does with its observation (the state at step i is in q and p).
    pub(super) fn take_observation(
        &mut self,
        i: u64,
        main: &[L; FIRST_BLOCK],
        blocks: &[L],
        event: bool,
    ) {
        {
            let (mut lanes, good) = parts!(self);
            let state = (self.st.q.get(), self.st.p.get(), self.st.u);
            // (the force was evaluated at φq_n = q_n: its grid values are the sample's q)
            let q_user = (self.q_from_grid && self.k.phi_is_identity)
                .then(|| self.pot.evaluated_in_user_coordinates::<L>(&self.ws))
                .flatten();
            lanes.observe(i, state, q_user, main, blocks, event, &good);
        }
        self.good.step = i;
        // The last good state is read only to keep it as a lane's last sample, which `keep`
        // skips where the lane keeps no samples or has one of this step already: then the
        // copies (at 2^16 coordinates 1.25 MiB per observation) are not made.
        let every_lane_has_it = self.record.save_every.is_none()
            || self
                .active
                .iter()
                .all(|b| self.lanes[b].samples.steps.last() == Some(&i));
        if every_lane_has_it {
            return;
        }
        self.good.q.clone_from(&self.st.q);
        self.good.p.clone_from(&self.st.p);
        self.good.main = *main;
        self.good.blocks.clone_from_slice(blocks);
    }

    /// The energy row of lane b in channel order.
    pub(super) fn row(&mut self, main: &[L; FIRST_BLOCK], blocks: &[L], b: usize) -> Vec<f64> {
        self.parts().0.row(main, blocks, b)
    }

    /// A stop request at step e: the running lanes end there, their last observed state kept.
    pub(super) fn end_interrupted(&mut self, e: u64) {
        let (mut lanes, good) = self.parts();
        lanes.interrupt(e, &good);
    }

    pub(super) fn outputs(&mut self) -> Vec<TrajectoryOutput> {
        finish(std::mem::take(&mut self.lanes), self.record.track)
    }
}

//! What a careful step records: blow-ups, running extremes, samples, a lane's end, and the
//! outputs of a finished bundle.

use super::bundle::Bundle;
use crate::energy::{max_deviation, FIRST_BLOCK, MODIFIED, OSCILLATORY, TOTAL};
use crate::output::{Status, TrajectoryOutput};
use crate::potential::Potential;
use crate::real::{LaneSet, Real};
use crate::shape::{Shape, Storage};

impl<'a, L: Real, Sh: Shape, P: Potential> Bundle<'a, L, Sh, P> {
    /// What a careful step does with its observation (the state at step i is in q and p).
    pub(super) fn take_observation(
        &mut self,
        i: u64,
        main: &[L; FIRST_BLOCK],
        blocks: &[L],
        event: bool,
    ) {
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
    pub(super) fn update_extremes(&mut self, main: &[L; FIRST_BLOCK], blocks: &[L], mask: LaneSet) {
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
    pub(super) fn row(&self, main: &[L; FIRST_BLOCK], blocks: &[L], b: usize) -> Vec<f64> {
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
    pub(super) fn keep(&mut self, b: usize, step: u64, q: &[L], p: &[L], row: Vec<f64>) {
        let s = &mut self.lanes[b].samples;
        if self.record.save_every.is_none() || s.steps.last() == Some(&step) {
            return;
        }
        s.steps.push(step);
        s.q.extend(q.iter().map(|x| x.lane(b)));
        s.p.extend(p.iter().map(|x| x.lane(b)));
        s.energies.extend(row);
    }

    pub(super) fn sample(&mut self, b: usize, step: u64, main: &[L; FIRST_BLOCK], blocks: &[L]) {
        let row = self.row(main, blocks, b);
        let (q, p) = (self.st.q.clone(), self.st.p.clone());
        self.keep(b, step, q.get(), p.get(), row);
    }

    /// Keeps lane b's last good state.
    pub(super) fn keep_good(&mut self, b: usize) {
        let row = self.row(&self.good.main, &self.good.blocks, b);
        let (q, p) = (self.good.q.clone(), self.good.p.clone());
        self.keep(b, self.good.step, q.get(), p.get(), row);
    }

    /// Lane b is not finite at step i: it ends at step i − 1, whose state is kept.
    pub(super) fn blow_up(&mut self, b: usize, i: u64) {
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
    pub(super) fn end_lane(&mut self, b: usize, status: Status, steps_done: u64) {
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
    pub(super) fn interrupt(&mut self, e: u64) {
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

    pub(super) fn finish(self) -> Vec<TrajectoryOutput> {
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

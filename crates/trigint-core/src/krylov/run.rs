//! The Krylov step as a [`Stepper`] of the one run loop: the state (q_n, p_n, g_n) of one
//! trajectory, stepped by [`Stepper`](super::Stepper)'s products, observed and recorded by the
//! run loop's own bookkeeping (the same sampling, record policy, blow-up replay, interruption and
//! messages as every other path).
//!
//! The tight loop tests every step (a Krylov step costs dozens of sparse products, so a test is
//! free): U, q and p finite, and that every Lanczos product reached its tolerance. A product
//! that did not ends the run at the last state, with a message that says why.

use super::{energies, Force, Stepper as Step, Stop};
use crate::energy::{Extremes, FIRST_BLOCK, TOTAL};
use crate::error::CoreResult;
use crate::output::{Record, TrajectoryOutput};
use crate::potential::Potential;
use crate::real::LaneSet;
use crate::run::{finish, Good, Lane, LaneBook, Stepper};

/// An observation: U and the main channels (the one block's energy is H_ω, so the row adds it).
type Observation = (f64, [f64; FIRST_BLOCK]);

pub(super) struct KrylovRun<'a, P: Potential> {
    pub(super) step: Step<'a, P>,
    record: Record,
    q: Vec<f64>,
    p: Vec<f64>,
    g: Force,
    q_next: Vec<f64>,
    p_next: Vec<f64>,
    g_next: Force,
    scratch: Vec<f64>,
    checkpoint: (Vec<f64>, Vec<f64>, Force, Extremes<f64>),
    good: (u64, Vec<f64>, Vec<f64>, [f64; FIRST_BLOCK]),
    ext: Extremes<f64>,
    lanes: Vec<Lane>,
    active: LaneSet,
}

/// The bookkeeping and the last good state, borrowed field by field.
macro_rules! parts {
    ($r:expr) => {
        (
            LaneBook {
                lanes: &mut $r.lanes,
                ext: &mut $r.ext,
                active: &mut $r.active,
                record: $r.record,
                n_blocks: 1,
                single_block: true,
                plain_modified: false,
            },
            Good {
                step: $r.good.0,
                q: &$r.good.1,
                p: &$r.good.2,
                main: &$r.good.3,
                blocks: &[],
            },
        )
    };
}

impl<'a, P: Potential> KrylovRun<'a, P> {
    pub(super) fn new(
        step: Step<'a, P>,
        q0: &[f64],
        p0: &[f64],
        n_steps: u64,
        record: Record,
    ) -> Self {
        let n = q0.len();
        let v = || vec![0.0; n];
        KrylovRun {
            step,
            record,
            q: q0.to_vec(),
            p: p0.to_vec(),
            g: Force::new(n),
            q_next: v(),
            p_next: v(),
            g_next: Force::new(n),
            scratch: v(),
            checkpoint: (v(), v(), Force::new(n), Extremes::new(1, 0)),
            good: (0, v(), v(), [f64::NAN; FIRST_BLOCK]),
            ext: Extremes::new(1, 0),
            lanes: vec![Lane::new(n_steps, FIRST_BLOCK + 1)],
            active: LaneSet::first(1),
        }
    }

    fn energies(&mut self, u: f64) -> [f64; FIRST_BLOCK] {
        energies(self.step.a, &mut self.scratch, &self.q, &self.p, u)
    }

    /// One step from the current state; on success the state is at the next step.
    fn advance(&mut self) -> CoreResult<Result<(), Stop>> {
        let r = self.step.step(
            &self.q,
            &self.p,
            &self.g,
            &mut self.q_next,
            &mut self.p_next,
            &mut self.g_next,
        )?;
        if r.is_ok() {
            std::mem::swap(&mut self.q, &mut self.q_next);
            std::mem::swap(&mut self.p, &mut self.p_next);
            std::mem::swap(&mut self.g, &mut self.g_next);
        }
        Ok(r)
    }

    /// The message of a step that could not be taken after step `done`.
    fn lanczos_failure(&self, done: u64) -> String {
        let (h, lz) = (self.step.h, self.step.settings);
        format!(
            "stopped before step {} (t = {}): the Lanczos method did not reach the tolerance {:e} in \
             {} steps (h·sqrt(largest eigenvalue) too large for this tolerance; take a smaller h or \
             a larger tol)",
            done + 1,
            (done + 1) as f64 * h,
            lz.tol,
            lz.max_iterations
        )
    }

    /// Records the observation of step i and keeps it as the last good one.
    fn take_observation(&mut self, i: u64, (u, main): Observation, event: bool) {
        {
            let (mut book, good) = parts!(self);
            book.observe(i, (&self.q, &self.p, u), None, &main, &[], event, &good);
        }
        self.good.0 = i;
        self.good.1.copy_from_slice(&self.q);
        self.good.2.copy_from_slice(&self.p);
        self.good.3 = main;
    }

    /// The running lane cannot be stepped past step `done`: it ends there.
    fn cannot_step(&mut self, done: u64) {
        let message = self.lanczos_failure(done);
        let (mut book, good) = parts!(self);
        book.cannot_step(&message, &good);
    }
}

impl<P: Potential> Stepper for KrylovRun<'_, P> {
    type Observation = Observation;
    type Output = Vec<TrajectoryOutput>;
    /// Events are cheap beside a Krylov step (one sparse product and two copies), and a replay
    /// costs whole steps: short segments.
    const SEGMENT: u64 = 64;

    fn active(&self) -> LaneSet {
        self.active
    }

    fn record(&self) -> Record {
        self.record
    }

    fn n_steps(&self, b: usize) -> u64 {
        self.lanes[b].n_steps
    }

    /// Observes step 0, evaluates g_0 and takes the first step.
    fn start(&mut self) -> CoreResult<()> {
        // U(q0) by itself (not the force pass's), as a reference for the energies.
        let u0 = self.step.value(&self.q, None)?;
        let main = self.energies(u0);
        self.lanes[0].initial = parts!(self).0.row(&main, &[], 0);
        self.take_observation(0, (u0, main), true);
        if self.active.is_empty() {
            return Ok(());
        }
        let mut g = std::mem::replace(&mut self.g, Force::new(0));
        let r = self.step.force(&self.q, &mut g);
        self.g = g;
        if r?.is_err() || self.advance()?.is_err() {
            self.cannot_step(0);
        }
        Ok(())
    }

    fn save_checkpoint(&mut self) {
        let (q, p, g, ext) = &mut self.checkpoint;
        q.copy_from_slice(&self.q);
        p.copy_from_slice(&self.p);
        g.copy_from(&self.g);
        ext.clone_from(&self.ext);
    }

    fn restore_checkpoint(&mut self) -> CoreResult<()> {
        let (q, p, g, ext) = &self.checkpoint;
        self.q.copy_from_slice(q);
        self.p.copy_from_slice(p);
        self.g.copy_from(g);
        self.ext.clone_from(ext);
        Ok(())
    }

    fn hot(&mut self, n: u64, e: u64) -> CoreResult<Option<u64>> {
        for i in n..e {
            let u = self.step.value(&self.q, self.g.value)?;
            let finite = u.is_finite()
                && self.q.iter().all(|x| x.is_finite())
                && self.p.iter().all(|x| x.is_finite());
            if !finite {
                return Ok(Some(i));
            }
            if self.record.track {
                let main = self.energies(u);
                let active = self.active;
                parts!(self).0.update_extremes(&main, &[], active);
            }
            if self.advance()?.is_err() {
                return Ok(Some(i));
            }
        }
        Ok(None)
    }

    fn observe(&mut self) -> CoreResult<Observation> {
        let u = self.step.value(&self.q, self.g.value)?;
        Ok((u, self.energies(u)))
    }

    fn nonfinite(&self, (_, main): &Observation) -> LaneSet {
        if main[TOTAL].is_finite() {
            LaneSet::default()
        } else {
            self.active
        }
    }

    fn careful(&mut self, i: u64, observation: Observation, event: bool) -> CoreResult<()> {
        self.take_observation(i, observation, event);
        if !self.active.is_empty() && self.advance()?.is_err() {
            self.cannot_step(i);
        }
        Ok(())
    }

    fn interrupt_at_last_observation(&mut self) {
        let step = self.good.0;
        self.interrupt(step);
    }

    fn interrupt(&mut self, e: u64) {
        let (mut book, good) = parts!(self);
        book.interrupt(e, &good);
    }

    fn finish(&mut self) -> Vec<TrajectoryOutput> {
        finish(std::mem::take(&mut self.lanes), self.record.track)
    }
}

//! The run loop, written once for every kind of step: a [`Stepper`] says how to step, observe
//! and go back to a checkpoint; [`drive`] decides when. Steps between events run in the
//! stepper's tight loop ([`Stepper::hot`]); an event (a sample, a lane's last step, a progress
//! report, a check every `SEGMENT` steps at most) is a careful step that observes the whole
//! state and records it through [`LaneBook`](super::record::LaneBook), the one record policy.
//! When the tight loop reports a lane that is not finite, the driver goes back to the checkpoint
//! at the start of the segment and replays it carefully (the same operations, so the same bits)
//! up to the first step that is not finite, so the last finite state is kept exactly.
//!
//! The steppers: [`Bundle`](super::Bundle) (the two-step recursion and the one-step form, every
//! instruction-set copy and lane loop), the Krylov step (`crate::krylov`) and the tangent step
//! of the recursion ([`tangent`](super::tangent)).
//!
//! A new kind of step implements [`Stepper`] in one file and calls [`run`]: sampling, `SaveAt`,
//! the record policy, blow-up and its replay, Ctrl-C, progress and the status messages come
//! from here and from `record`.

use std::sync::atomic::{AtomicBool, Ordering};

use crate::error::{CoreError, CoreResult};
use crate::output::Record;
use crate::real::LaneSet;

/// How a run reports progress and learns that it should stop.
pub struct Control<'c> {
    /// Steps between reports (also how often a stop request is noticed).
    pub every: u64,
    /// Called with the step reached; returning false stops the run ("interrupted").
    pub report: &'c mut dyn FnMut(u64) -> bool,
}

impl Control<'_> {
    /// Runs `f` with a control that reports nothing and stops once `stop` is set, polled every
    /// `poll` steps: each trajectory or bundle of a batch, whose caller watches for Ctrl-C.
    pub(crate) fn polling<R>(stop: &AtomicBool, poll: u64, f: impl FnOnce(&mut Control) -> R) -> R {
        let mut go_on = |_| !stop.load(Ordering::Relaxed);
        f(&mut Control {
            every: poll.max(1),
            report: &mut go_on,
        })
    }
}

/// One kind of step, as the run loop sees it. Between calls the stepper holds the state of the
/// step the driver names: `start` leaves it at step 1, `hot(n, e)` takes it from n to e,
/// `careful(i, …)` from i to i + 1. (A stepper with `SEGMENT = 1` is never asked for a tight
/// loop or a replay, so it may take step i − 1 → i in `observe` instead, as the Krylov tangent
/// does: its careful step then leaves the state at i, which an interruption returns.)
pub(crate) trait Stepper {
    /// What observing the state yields (the energy sums of every lane).
    type Observation;
    /// What a finished run returns.
    type Output;
    /// Steps between events at most: this bounds the cost of a replay.
    const SEGMENT: u64;

    /// The lanes still running.
    fn active(&self) -> LaneSet;
    /// What the run records.
    fn record(&self) -> Record;
    /// The last step of lane b.
    fn n_steps(&self, b: usize) -> u64;
    /// The stepper's own next event at or after step n (the tangent's renormalizations).
    fn own_event(&self, _n: u64) -> u64 {
        u64::MAX
    }
    /// Step 0: observe (q_0, p_0), record it, and advance to step 1.
    fn start(&mut self) -> CoreResult<()>;
    fn save_checkpoint(&mut self);
    fn restore_checkpoint(&mut self) -> CoreResult<()>;
    /// Steps n..e−1 without recording. Returns a step at or before which a running lane turned
    /// non-finite (or could not be stepped), leaving the state to be restored and replayed;
    /// otherwise the state is at step e.
    fn hot(&mut self, n: u64, e: u64) -> CoreResult<Option<u64>>;
    /// Observes the current state.
    fn observe(&mut self) -> CoreResult<Self::Observation>;
    /// The running lanes whose observation is not finite.
    fn nonfinite(&self, observation: &Self::Observation) -> LaneSet;
    /// Records the observation of step i (lanes not finite blow up; samples and ends at
    /// events), keeps it as the last good one, and advances to step i + 1. A stepper that cannot
    /// take the step ends its running lanes there itself, with a message that says why.
    fn careful(&mut self, i: u64, observation: Self::Observation, event: bool) -> CoreResult<()>;
    /// The running lanes end at the last observed step, "interrupted".
    fn interrupt_at_last_observation(&mut self);
    /// The running lanes end at step e (observed), "interrupted".
    fn interrupt(&mut self, e: u64);
    /// The outputs of every lane (taken out of the stepper).
    fn finish(&mut self) -> Self::Output;
}

/// Runs every lane of `stepper` to its last step (or blow-up, or interruption).
pub(crate) fn run<S: Stepper>(stepper: &mut S, control: &mut Control) -> CoreResult<S::Output> {
    match drive(stepper, control) {
        Ok(()) => {}
        // Stopped from inside the potential: end at the last observed state.
        Err(CoreError::Interrupted) => stepper.interrupt_at_last_observation(),
        Err(e) => return Err(e),
    }
    Ok(stepper.finish())
}

#[inline(always)]
fn drive<S: Stepper>(s: &mut S, control: &mut Control) -> CoreResult<()> {
    s.start()?;
    let mut n = 1;
    while !s.active().is_empty() {
        let e = next_event(s, n, control.every);
        // (a segment of no steps, as when every step is sampled, needs no checkpoint)
        if e > n {
            s.save_checkpoint();
        }
        if let Some(j) = s.hot(n, e)? {
            // A lane is not finite at step j or before: replay n..=j carefully.
            s.restore_checkpoint()?;
            for i in n..=j {
                let o = s.observe()?;
                s.careful(i, o, false)?;
            }
            n = j + 1;
            continue;
        }
        let mut o = s.observe()?;
        if e > n && !s.nonfinite(&o).is_empty() {
            // The last good state is at n − 1, not e − 1: replay the segment carefully.
            s.restore_checkpoint()?;
            for i in n..e {
                let o = s.observe()?;
                s.careful(i, o, false)?;
            }
            o = s.observe()?;
        }
        s.careful(e, o, true)?;
        if !s.active().is_empty() && e.is_multiple_of(control.every) && !(control.report)(e) {
            s.interrupt(e);
        }
        n = e + 1;
    }
    Ok(())
}

/// The next step that needs a careful observation.
fn next_event<S: Stepper>(s: &S, n: u64, every: u64) -> u64 {
    let up_to_multiple = |k: u64| n.div_ceil(k) * k;
    let mut e = n.saturating_add(S::SEGMENT - 1);
    if let Some(k) = s.record().save_every {
        e = e.min(up_to_multiple(k));
    }
    e = e.min(up_to_multiple(every.max(1))).min(s.own_event(n));
    for b in s.active().iter() {
        e = e.min(s.n_steps(b));
    }
    e
}

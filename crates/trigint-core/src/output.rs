//! What a run is asked to keep, and what it returns: one record policy and one output type for
//! a single trajectory and for every trajectory of a batch.

use crate::energy::Samples;

/// Which form of the recursion to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Form {
    /// (2.2)/(2.5): the two-step recursion with central-difference momenta.
    TwoStep,
    /// The one-step (velocity) form.
    OneStep,
}

/// What to keep of a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Record {
    /// Keep the state every this many steps (and at the last step); None: only the max
    /// deviations and the initial energies.
    pub save_every: Option<u64>,
    /// Track every energy at every step (max deviation); otherwise only at the samples.
    pub track: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Status {
    Completed,
    /// The state became non-finite; `steps_done` is the last finite step, kept as a sample.
    BlowUp,
    /// Asked to stop; `steps_done` is the step reached, kept as a sample.
    Interrupted,
}

impl Status {
    pub fn as_str(self) -> &'static str {
        match self {
            Status::Completed => "completed",
            Status::BlowUp => "blow-up",
            Status::Interrupted => "interrupted",
        }
    }
}

/// The result for one trajectory.
#[derive(Debug, Clone, PartialEq)]
pub struct TrajectoryOutput {
    pub status: Status,
    /// The last step whose state was observed and finite.
    pub steps_done: u64,
    /// The energies at step 0, in channel order (NaN if the initial state is not finite).
    pub initial_energies: Vec<f64>,
    /// max_n |E(t_n) − E(0)| per channel over every step (NaN when not tracked).
    pub max_deviation: Vec<f64>,
    pub samples: Samples,
    /// What happened, in words.
    pub message: String,
}

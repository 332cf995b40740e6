//! The driver owns the bookkeeping: validation, the choice of kernel and storage, step
//! counting, progress reports between chunks of steps, blow-up and interruption.

use crate::coefficients::MethodCoefficients;
use crate::energy::{EnergyLayout, Recorder, Samples};
use crate::error::{CoreError, CoreResult};
use crate::potential::Potential;
use crate::stepper::{OneStep, Stepper, TwoStep};

/// Which form of the recursion to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Form {
    /// (trigo)/(trigo-mod): the two-step recursion with central-difference momenta.
    TwoStep,
    /// The one-step (velocity) form.
    OneStep,
}

/// What one run is asked to do.
#[derive(Debug, Clone)]
pub struct RunSpec {
    pub n_steps: u64,
    pub save_every: u64,
    pub form: Form,
    /// Track every channel at every step (max deviation); otherwise only at samples.
    pub track_energies: bool,
    /// Steps between progress reports (and interruption checks).
    pub progress_every: u64,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Status {
    Completed,
    /// The state became non-finite; `steps_done` is the last finite step.
    BlowUp,
    /// The progress callback asked to stop.
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

/// The result of a run: its status, the samples and the streamed diagnostics.
#[derive(Debug, Clone)]
pub struct RunOutput {
    pub status: Status,
    /// The last step whose state was observed and finite.
    pub steps_done: u64,
    pub samples: Samples,
    pub initial_energies: Vec<f64>,
    pub max_deviation: Vec<f64>,
    pub message: String,
}

/// Integrates q'' + Ω²q = g(q) from (q0, p0) with the given per-coordinate method
/// coefficients. `progress(steps_done)` is called every `spec.progress_every` steps; it
/// returns false to interrupt.
pub fn integrate<P: Potential>(
    pot: &P,
    coefficients: &MethodCoefficients,
    layout: &EnergyLayout,
    q0: &[f64],
    p0: &[f64],
    spec: &RunSpec,
    progress: &mut dyn FnMut(u64) -> bool,
) -> CoreResult<RunOutput> {
    coefficients.validate()?;
    let n = coefficients.dim();
    for (name, v) in [("q0", q0), ("p0", p0)] {
        if v.len() != n {
            return Err(CoreError::invalid(
                name,
                format!("has {} entries, the method has {n} coordinates", v.len()),
            ));
        }
        if let Some(i) = v.iter().position(|x| !x.is_finite()) {
            return Err(CoreError::invalid(
                name,
                format!("entry {i} is not finite ({})", v[i]),
            ));
        }
    }
    pot.check_dim(n)?;
    layout.validate(n)?;
    if spec.save_every == 0 {
        return Err(CoreError::invalid("save_every", "must be >= 1"));
    }
    let k = coefficients.kernel();
    // Fixed-size storage for the small problems where loop overhead dominates.
    macro_rules! dispatch {
        ($($dim:literal)*) => {
            match (n, spec.form) {
                $(
                    ($dim, Form::TwoStep) => run::<Inline, _>(TwoStep::<P, [f64; $dim]>::new(pot, &k), layout, q0, p0, spec, progress),
                    ($dim, Form::OneStep) => run::<Inline, _>(OneStep::<P, [f64; $dim]>::new(pot, &k), layout, q0, p0, spec, progress),
                )*
                (_, Form::TwoStep) => run::<Wide, _>(TwoStep::<P, Vec<f64>>::new(pot, &k), layout, q0, p0, spec, progress),
                (_, Form::OneStep) => run::<Wide, _>(OneStep::<P, Vec<f64>>::new(pot, &k), layout, q0, p0, spec, progress),
            }
        };
    }
    dispatch!(1 2 3 4 6 8)
}

/// How a chunk of steps is run: inlined into the step loop (small states, where the loop is
/// latency-bound and best left alone), or through copies compiled for the widest vectors this CPU
/// has (large states). The copies differ only in instruction encoding (no fused multiply-add is
/// ever formed), so every choice gives the same bits.
trait Steps {
    /// Steps from `done` to `upto`; returns the last step reached and whether it was finite.
    fn steps<K: Stepper>(
        kernel: &mut K,
        rec: &mut Recorder<K::S>,
        done: u64,
        upto: u64,
    ) -> CoreResult<(u64, bool)>;
}

#[inline(always)]
fn steps_inline<K: Stepper>(
    kernel: &mut K,
    rec: &mut Recorder<K::S>,
    mut done: u64,
    upto: u64,
) -> CoreResult<(u64, bool)> {
    while done < upto {
        if !kernel.step(rec)? {
            return Ok((done, false));
        }
        done += 1;
    }
    Ok((done, true))
}

struct Inline;

impl Steps for Inline {
    #[inline(always)]
    fn steps<K: Stepper>(
        kernel: &mut K,
        rec: &mut Recorder<K::S>,
        done: u64,
        upto: u64,
    ) -> CoreResult<(u64, bool)> {
        steps_inline(kernel, rec, done, upto)
    }
}

struct Wide;

impl Steps for Wide {
    fn steps<K: Stepper>(
        kernel: &mut K,
        rec: &mut Recorder<K::S>,
        done: u64,
        upto: u64,
    ) -> CoreResult<(u64, bool)> {
        #[cfg(target_arch = "x86_64")]
        {
            if std::is_x86_feature_detected!("avx512f") {
                // SAFETY: the CPU supports AVX-512F, checked just above.
                return unsafe { steps_avx512(kernel, rec, done, upto) };
            }
            if std::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU supports AVX2, checked just above.
                return unsafe { steps_avx2(kernel, rec, done, upto) };
            }
        }
        steps_inline(kernel, rec, done, upto)
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn steps_avx512<K: Stepper>(
    kernel: &mut K,
    rec: &mut Recorder<K::S>,
    done: u64,
    upto: u64,
) -> CoreResult<(u64, bool)> {
    steps_inline(kernel, rec, done, upto)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn steps_avx2<K: Stepper>(
    kernel: &mut K,
    rec: &mut Recorder<K::S>,
    done: u64,
    upto: u64,
) -> CoreResult<(u64, bool)> {
    steps_inline(kernel, rec, done, upto)
}

/// The step loop: chunks of steps between progress reports, blow-up and interruption.
fn run<W: Steps, K: Stepper>(
    mut kernel: K,
    layout: &EnergyLayout,
    q0: &[f64],
    p0: &[f64],
    spec: &RunSpec,
    progress: &mut dyn FnMut(u64) -> bool,
) -> CoreResult<RunOutput> {
    let mut rec = Recorder::<K::S>::new(layout, spec.track_energies, spec.save_every, spec.n_steps);
    let finish =
        |rec: Recorder<K::S>, status: Status, steps_done: u64, message: String| RunOutput {
            status,
            steps_done,
            initial_energies: rec.initial().to_vec(),
            max_deviation: rec.max_deviation(),
            samples: rec.samples,
            message,
        };
    if !kernel.start(q0, p0, &mut rec)? {
        return Ok(finish(
            rec,
            Status::BlowUp,
            0,
            "the initial state is not finite".into(),
        ));
    }
    let chunk = spec.progress_every.max(1);
    let mut done = 0u64; // the last observed step
    while done < spec.n_steps {
        let upto = spec.n_steps.min(done.saturating_add(chunk));
        let finite;
        (done, finite) = W::steps(&mut kernel, &mut rec, done, upto)?;
        if !finite {
            let message = format!(
                "the solution blew up: the state at step {} is not finite; kept the samples up to step {done}",
                done + 1
            );
            return Ok(finish(rec, Status::BlowUp, done, message));
        }
        if !progress(done) {
            let message = format!(
                "interrupted after step {done} of {}; kept the samples up to there",
                spec.n_steps
            );
            return Ok(finish(rec, Status::Interrupted, done, message));
        }
    }
    Ok(finish(
        rec,
        Status::Completed,
        done,
        format!("completed {done} steps"),
    ))
}

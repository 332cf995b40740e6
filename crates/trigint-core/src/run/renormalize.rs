//! What every tangent run shares, whatever its step: the request and the output, the checks of
//! the deviations, and the bookkeeping of Benettin's method (Benettin, Galgani, Giorgilli,
//! Strelcyn 1980): modified Gram–Schmidt of the deviation vectors in the caller's metric every
//! `renormalize_every` steps, Σ ln R_jj per vector, the MEGNO of the first (Cincotta, Simó 2000)
//! and the samples. A step kind brings its own deviation recursion and hands its vectors here.

use super::check_state;
use crate::error::{CoreError, CoreResult};
use crate::output::Status;
use crate::real::{LaneSet, Real};

/// What a tangent run is asked for.
#[derive(Clone, Debug)]
pub struct TangentRequest {
    pub n_steps: u64,
    /// Steps between re-orthonormalizations; 0: never (the raw tangent map, for checking it).
    pub renormalize_every: u64,
    /// A sample is recorded at every re-orthonormalization whose step is a multiple of this
    /// (and at the last step).
    pub sample_every: u64,
}

/// The result of a tangent run, in the core's coordinates.
#[derive(Clone, Debug)]
pub struct TangentOutput {
    /// Steps of the samples.
    pub steps: Vec<u64>,
    /// Per sample, Σ ln R_jj of each vector up to that step (divide by t for the exponents).
    pub log_growth: Vec<Vec<f64>>,
    /// Per sample, the time-averaged MEGNO ⟨Y⟩ of the first vector.
    pub megno: Vec<f64>,
    /// The deviations at the last step reached (K × n each): orthonormal when renormalizing,
    /// else the tangent map applied to the initial ones.
    pub dq: Vec<f64>,
    pub dp: Vec<f64>,
    /// The state at the last step reached (q_n, p_n).
    pub q: Vec<f64>,
    pub p: Vec<f64>,
    pub steps_done: u64,
    pub status: Status,
    pub message: String,
}

/// MEGNO of the first vector over the renormalization times t_i:
/// Y(t_k) = (2/t_k) Σ_{i≤k} t_i ln(‖δ(t_i)‖/‖δ(t_{i−1})‖), ⟨Y⟩(t_k) = (1/t_k) Σ_{i≤k} Y(t_i)(t_i − t_{i−1}).
#[derive(Default)]
struct Megno {
    weighted: f64,
    integral: f64,
    last_t: f64,
}

impl Megno {
    fn add(&mut self, t: f64, log_growth: f64) {
        self.weighted += t * log_growth;
        let y = 2.0 * self.weighted / t;
        self.integral += y * (t - self.last_t);
        self.last_t = t;
    }

    /// ⟨Y⟩ at the last time added (a division: only where a sample is taken).
    fn mean(&self) -> f64 {
        self.integral / self.last_t
    }
}

/// Checks a tangent run's deviations (K × n rows each), metric and request; returns K.
pub(crate) fn check_tangent(
    n: usize,
    dq0: &[f64],
    dp0: &[f64],
    metric: &[f64],
    request: &TangentRequest,
) -> CoreResult<usize> {
    if request.n_steps == 0 {
        return Err(CoreError::invalid("n_steps", "must be >= 1"));
    }
    if request.sample_every == 0 {
        return Err(CoreError::invalid("sample_every", "must be >= 1"));
    }
    if dq0.is_empty() || !dq0.len().is_multiple_of(n) || dp0.len() != dq0.len() {
        return Err(CoreError::invalid(
            "deviation",
            format!(
                "expected K x {n} values in each of dq0 and dp0, got {} and {}",
                dq0.len(),
                dp0.len()
            ),
        ));
    }
    let k = dq0.len() / n;
    if k > 2 * n {
        return Err(CoreError::invalid(
            "n_exponents",
            format!("at most 2n = {} deviation vectors, got {k}", 2 * n),
        ));
    }
    check_state("deviation", dq0, k * n, "dq0: ")?;
    check_state("deviation", dp0, k * n, "dp0: ")?;
    if metric.len() != n || metric.iter().any(|w| !(w.is_finite() && *w > 0.0)) {
        return Err(CoreError::invalid(
            "metric",
            format!("expected {n} finite positive weights"),
        ));
    }
    Ok(k)
}

impl TangentOutput {
    /// Nothing recorded yet: a run that completes unless told otherwise.
    pub(crate) fn empty() -> Self {
        TangentOutput {
            steps: Vec::new(),
            log_growth: Vec::new(),
            megno: Vec::new(),
            dq: Vec::new(),
            dp: Vec::new(),
            q: Vec::new(),
            p: Vec::new(),
            steps_done: 0,
            status: Status::Completed,
            message: String::new(),
        }
    }
}

/// Benettin's bookkeeping of one run.
pub(crate) struct Renormalizer<'m> {
    k: usize,
    n: usize,
    metric: &'m [f64],
    h: f64,
    request: TangentRequest,
    sums: Vec<f64>,
    logs: Vec<f64>,
    megno: Megno,
    /// The step of the latest re-orthonormalization (0: none yet).
    last: u64,
    pub(crate) out: TangentOutput,
}

impl<'m> Renormalizer<'m> {
    pub(crate) fn new(
        k: usize,
        n: usize,
        metric: &'m [f64],
        h: f64,
        request: &TangentRequest,
    ) -> Self {
        Renormalizer {
            k,
            n,
            metric,
            h,
            request: request.clone(),
            sums: vec![0.0; k],
            logs: vec![0.0; k],
            megno: Megno::default(),
            last: 0,
            out: TangentOutput::empty(),
        }
    }

    /// What the run was asked for.
    pub(crate) fn request(&self) -> &TangentRequest {
        &self.request
    }

    /// Whether the vectors are re-orthonormalized at `step`.
    #[inline(always)]
    pub(crate) fn due(&self, step: u64) -> bool {
        self.request.renormalize_every > 0
            && (step.is_multiple_of(self.request.renormalize_every) || step == self.request.n_steps)
    }

    fn dot(&self, x: &[f64], y: &[f64], u: &[f64], v: &[f64]) -> f64 {
        let w = self.metric;
        let mut s = 0.0;
        for i in 0..self.n {
            s += w[i] * (x[i] * y[i] + u[i] * v[i]);
        }
        s
    }

    /// Modified Gram–Schmidt on the vectors (rows of `yq`, `yp`, K × n) in the metric, the same
    /// combinations applied to the rows of each of `extra` (what else of a vector the step
    /// carries: the recursion is linear in the deviation, so this is exact); then Σ ln R_jj,
    /// the MEGNO and, when due, a sample.
    pub(crate) fn renormalize(
        &mut self,
        step: u64,
        yq: &mut [f64],
        yp: &mut [f64],
        extra: &mut [&mut [f64]],
    ) {
        let n = self.n;
        for j in 0..self.k {
            for i in 0..j {
                let r = self.dot(
                    &yq[i * n..(i + 1) * n],
                    &yq[j * n..(j + 1) * n],
                    &yp[i * n..(i + 1) * n],
                    &yp[j * n..(j + 1) * n],
                );
                for v in [&mut *yq, &mut *yp]
                    .into_iter()
                    .chain(extra.iter_mut().map(|e| &mut **e))
                {
                    for t in 0..n {
                        v[j * n + t] -= r * v[i * n + t];
                    }
                }
            }
            let (qj, pj) = (&yq[j * n..(j + 1) * n], &yp[j * n..(j + 1) * n]);
            let norm = self.dot(qj, qj, pj, pj).sqrt();
            self.logs[j] = norm.ln();
            // One division and multiplications (a vector division is slow, and the bundled
            // tangent does the same in its lanes: the same bits).
            let inv = 1.0 / norm;
            for v in [&mut *yq, &mut *yp]
                .into_iter()
                .chain(extra.iter_mut().map(|e| &mut **e))
            {
                for x in &mut v[j * n..(j + 1) * n] {
                    *x *= inv;
                }
            }
        }
        let logs = std::mem::take(&mut self.logs);
        self.grown(step, &logs);
        self.logs = logs;
    }

    /// Adds the vectors' log growths ln R_jj at a re-orthonormalization at `step` (done by the
    /// caller, as [`renormalize`](Self::renormalize) does it): Σ ln R_jj, the MEGNO and, when due,
    /// a sample.
    pub(crate) fn grown(&mut self, step: u64, logs: &[f64]) {
        for (s, l) in self.sums.iter_mut().zip(logs) {
            *s += l;
        }
        self.megno.add(step as f64 * self.h, logs[0]);
        self.last = step;
        // (The first test spares an integer division where samples are rare: a batch's.)
        let every = self.request.sample_every;
        if step == self.request.n_steps || (step >= every && step.is_multiple_of(every)) {
            let y = self.megno.mean();
            self.out.steps.push(step);
            self.out.log_growth.push(self.sums.clone());
            self.out.megno.push(y);
        }
    }

    /// A last sample at the latest re-orthonormalization (where the numbers of a run that
    /// ends early stop), unless that was sampled: the exponents of a run that blew up are those
    /// there, whatever its samples' spacing (an ensemble's lanes, sampled at their last step
    /// only, give the same).
    pub(crate) fn sample_last(&mut self) {
        if self.last > 0 && self.out.steps.last() != Some(&self.last) {
            self.out.steps.push(self.last);
            self.out.log_growth.push(self.sums.clone());
            self.out.megno.push(self.megno.mean());
        }
    }

    /// Ends the run at a non-finite state found at `step`, with its [last
    /// sample](Self::sample_last).
    pub(crate) fn blow_up(&mut self, step: u64, what: &str) {
        self.sample_last();
        self.out.status = Status::BlowUp;
        self.out.message = format!(
            "{what} is not finite at step {step} (t = {}): stopped, keeping the samples before it",
            step as f64 * self.h
        );
    }

    /// Ends the run on a stop request at `step`.
    pub(crate) fn interrupt(&mut self, step: u64) {
        self.out.status = Status::Interrupted;
        self.out.message = format!("interrupted at step {step}");
    }
}

/// [`Renormalizer::grown`] for one vector in many lanes at once (the bundled tangent's): Σ ln R
/// and the MEGNO of each lane in the bundle's arithmetic, the same operations per lane, and a
/// lane's sample taken at its last step (where a batch samples).
pub(crate) struct LaneGrowth<L> {
    h: L,
    sums: L,
    weighted: L,
    integral: L,
    last_t: L,
    /// Each lane's latest re-orthonormalization (0: none yet).
    last_step: Vec<u64>,
}

impl<L: Real> LaneGrowth<L> {
    /// Lanes with step sizes `h`.
    pub(crate) fn new(h: L) -> Self {
        LaneGrowth {
            h,
            sums: L::zero(),
            weighted: L::zero(),
            integral: L::zero(),
            last_t: L::zero(),
            last_step: vec![0; L::LANES],
        }
    }

    /// The log growths `logs` of the lanes `due` at `step` (the other lanes keep their numbers).
    pub(crate) fn grown(&mut self, step: u64, logs: L, due: LaneSet) {
        let old = [self.sums, self.weighted, self.integral, self.last_t];
        let t = L::splat(step as f64) * self.h;
        self.sums += logs;
        self.weighted += t * logs;
        let y = L::splat(2.0) * self.weighted / t;
        self.integral += y * (t - self.last_t);
        self.last_t = t;
        for l in due.iter() {
            self.last_step[l] = step;
        }
        if due != LaneSet::first(L::LANES) {
            let new = [
                &mut self.sums,
                &mut self.weighted,
                &mut self.integral,
                &mut self.last_t,
            ];
            for (x, was) in new.into_iter().zip(old) {
                for l in (0..L::LANES).filter(|&l| !due.contains(l)) {
                    x.set_lane(l, was.lane(l));
                }
            }
        }
    }

    /// Lane l's sample at its latest re-orthonormalization, for a lane that blew up (as
    /// [`Renormalizer::sample_last`] takes it); none where there was none.
    pub(crate) fn sample_last(&self, l: usize, out: &mut TangentOutput) {
        let step = self.last_step[l];
        if step > 0 && out.steps.last() != Some(&step) {
            self.sample(l, step, out);
        }
    }

    /// Lane l's sample at `step` into `out`, as [`Renormalizer::grown`] takes it.
    pub(crate) fn sample(&self, l: usize, step: u64, out: &mut TangentOutput) {
        out.steps.push(step);
        out.log_growth.push(vec![self.sums.lane(l)]);
        out.megno.push(self.integral.lane(l) / self.last_t.lane(l));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A run that ends early (a blow-up, a Lanczos product that did not converge) takes a last
    /// sample at its latest re-orthonormalization, once, whatever the samples' spacing.
    #[test]
    fn a_run_that_ends_early_is_sampled_at_its_last_renormalization() {
        let request = TangentRequest {
            n_steps: 1000,
            renormalize_every: 16,
            sample_every: 64,
        };
        let metric = [1.0; 2];
        let mut book = Renormalizer::new(1, 2, &metric, 0.5, &request);
        for (step, log) in [(16, 0.25), (32, 0.5), (48, 1.0)] {
            book.grown(step, &[log]);
        }
        assert!(book.out.steps.is_empty(), "no sample due before step 64");
        book.blow_up(50, "the trajectory");
        assert_eq!(book.out.steps, [48]);
        assert_eq!(book.out.log_growth, [vec![1.75]]);
        assert_eq!(book.out.status, Status::BlowUp);
        book.sample_last();
        assert_eq!(book.out.steps, [48], "sampled once");
        // a run that was just sampled there, and one with no re-orthonormalization, add none
        let mut sampled = Renormalizer::new(1, 2, &metric, 0.5, &request);
        sampled.grown(64, &[0.5]);
        sampled.blow_up(70, "the trajectory");
        assert_eq!(sampled.out.steps, [64]);
        let mut none = Renormalizer::new(1, 2, &metric, 0.5, &request);
        none.blow_up(3, "the trajectory");
        assert!(none.out.steps.is_empty());
    }
}

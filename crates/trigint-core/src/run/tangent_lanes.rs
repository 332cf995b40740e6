//! The tangent step of many trajectories at once: the leading Lyapunov exponents of an
//! ensemble's or a scan's trajectories (`ensemble(..., lyapunov=k)`), each trajectory's numbers
//! those of [`tangent`] on it alone, bit for bit, whatever the bundle or the thread count.
//!
//! On a compile-time shape whose potential has an inline force and derivative (the FPU chain of
//! the paper), the trajectories go in bundles of lanes, and the steps between events run as
//! the bundle's lane loop runs them ([`lanes`](super::lanes)): as loops over the lanes whose
//! bodies are one trajectory's numbers in `f64`, which the compiler vectorizes across the
//! lanes. First the trajectories' step, keeping φq_n per lane; then each deviation's, which is
//! the same recursion (2.5) with the force replaced by G(φq_n)φδq_n: [`recursion::two_step`] on
//! a deviation's state. The events (the re-orthonormalizations, the checks, each lane's last
//! step) are careful steps in the bundle's own arithmetic, which gives the same numbers per
//! lane. Other potentials and shapes run [`tangent`] per trajectory, in parallel.

use std::sync::atomic::AtomicBool;

use rayon::prelude::*;

use super::bundle::CHECK;
use super::drive::{run, Control, Stepper};
use super::renormalize::{check_tangent, LaneGrowth, Renormalizer, TangentOutput, TangentRequest};
use super::tangent::tangent;
use super::tangent_loop::{lane_loop, scaled_deviation, Renorm};
use super::{check_batch, uniform};
use crate::coefficients::{Coef, MethodCoefficients, Weights};
use crate::error::CoreResult;
use crate::output::Record;
use crate::potential::Potential;
use crate::real::{LaneSet, Real, Scalar};
use crate::recursion::{self, State};
use crate::shape::{Fixed, Layout, Shape, Storage};

/// Runs [`tangent`] on every trajectory of a batch: each with its own method numbers, initial
/// values (row-major, B × n) and step count, the same deviations (`dq0`, `dp0`, K × n), metric
/// and `renormalize_every`, one sample at the last step (`steps`, `log_growth` and `megno` of
/// the outputs; their states and deviations are left empty). `stop` is polled every `poll`
/// steps; once set, unfinished trajectories end "interrupted".
#[allow(clippy::too_many_arguments)]
pub fn tangent_batch<L: Real, P: Potential>(
    pot: &P,
    layout: &Layout,
    methods: &[MethodCoefficients],
    q0: &[f64],
    p0: &[f64],
    n_steps: &[u64],
    deviation: (&[f64], &[f64]),
    metric: &[f64],
    renormalize_every: u64,
    stop: &AtomicBool,
    poll: u64,
) -> CoreResult<Vec<TangentOutput>> {
    layout.validate()?;
    pot.check_dim(layout.dim())?;
    check_batch(layout.dim(), methods, q0, p0, n_steps, true)?;
    let n = layout.dim();
    let request = |s: u64| TangentRequest {
        n_steps: s,
        renormalize_every,
        sample_every: s,
    };
    let (dq0, dp0) = deviation;
    check_tangent(n, dq0, dp0, metric, &request(1))?;
    let all: Vec<&MethodCoefficients> = methods.iter().collect();
    let batch = Batch {
        methods: &all,
        q0,
        p0,
        n_steps,
        dq0,
        dp0,
        metric,
        renormalize_every,
        stop,
        poll,
    };
    let bundled = with_shape!(layout, &all, L::LANES, |sh, _One| in_bundles::<L, _, P>(
        sh, pot, &batch
    ));
    if let Some(out) = bundled {
        return out;
    }
    (0..methods.len())
        .into_par_iter()
        .map(|t| {
            let (q, p) = (&q0[t * n..(t + 1) * n], &p0[t * n..(t + 1) * n]);
            let request = request(n_steps[t]);
            let mut out = Control::polling(stop, poll, |control| {
                tangent(
                    pot,
                    layout,
                    &methods[t],
                    q,
                    p,
                    dq0,
                    dp0,
                    metric,
                    &request,
                    control,
                )
            })?;
            (out.q, out.p, out.dq, out.dp) = Default::default();
            Ok(out)
        })
        .collect()
}

/// A validated batch.
struct Batch<'b> {
    methods: &'b [&'b MethodCoefficients],
    q0: &'b [f64],
    p0: &'b [f64],
    n_steps: &'b [u64],
    dq0: &'b [f64],
    dp0: &'b [f64],
    metric: &'b [f64],
    renormalize_every: u64,
    stop: &'b AtomicBool,
    poll: u64,
}

/// The batch in bundles of `L::LANES` lanes, or None where the lane loop does not serve.
fn in_bundles<L: Real, Sh: Shape, P: Potential>(
    sh: &Sh,
    pot: &P,
    b: &Batch,
) -> Option<CoreResult<Vec<TangentOutput>>> {
    let lane_loop = Sh::FIXED
        && P::INLINE_FORCE
        && L::LANES > 1
        && std::mem::size_of::<L>() == 8 * L::LANES
        && pot.inline_force_ready();
    if !lane_loop {
        return None;
    }
    let (n, count) = (sh.n(), b.methods.len());
    // Neighbours in step count share a bundle, so few lanes idle while others finish.
    let mut order: Vec<usize> = (0..count).collect();
    order.sort_by_key(|&t| b.n_steps[t]);
    let bundles: Vec<&[usize]> = order.chunks(L::LANES).collect();
    let results: Vec<CoreResult<Vec<TangentOutput>>> = bundles
        .par_iter()
        .map(|ids| {
            let lanes: Vec<Trajectory> = ids
                .iter()
                .map(|&t| Trajectory {
                    method: b.methods[t],
                    q0: &b.q0[t * n..(t + 1) * n],
                    p0: &b.p0[t * n..(t + 1) * n],
                    n_steps: b.n_steps[t],
                })
                .collect();
            let mut bundle = LaneTangent::<L, Sh, P>::new(sh, pot, &lanes, b);
            Control::polling(b.stop, b.poll, |control| run(&mut bundle, control))
        })
        .collect();
    let mut out: Vec<Option<TangentOutput>> = vec![None; count];
    for (ids, result) in bundles.iter().zip(results) {
        match result {
            Ok(outputs) => {
                for (&t, o) in ids.iter().zip(outputs) {
                    out[t] = Some(o);
                }
            }
            Err(e) => return Some(Err(e)),
        }
    }
    Some(Ok(out
        .into_iter()
        .map(|o| o.expect("every trajectory belongs to one bundle"))
        .collect()))
}

/// One lane's trajectory.
struct Trajectory<'t> {
    method: &'t MethodCoefficients,
    q0: &'t [f64],
    p0: &'t [f64],
    n_steps: u64,
}

/// q and d of the trajectories, δq and δd of each vector, at the start of a segment.
type Checkpoint<L, Sh> = (<Sh as Shape>::S<L>, <Sh as Shape>::S<L>, Vec<Row2<L, Sh>>);
type Row2<L, Sh> = (<Sh as Shape>::S<L>, <Sh as Shape>::S<L>);

/// A bundle of trajectories with their deviation vectors: the [`Stepper`].
struct LaneTangent<'a, L: Real, Sh: Shape, P: Potential> {
    sh: &'a Sh,
    pot: &'a P,
    ws: P::Workspace<L>,
    k: Coef<L, Sh::S<L>>,
    w: Weights<L, Sh::S<L>>,
    metric: Vec<L>,
    metric_f64: &'a [f64],
    st: State<L, Sh>,
    /// Each deviation vector as a state of the recursion: δq, δd, δp_0 and, during a step,
    /// G(φq_n)φδq_n in place of the force.
    dev: Vec<State<L, Sh>>,
    /// δq_n and δd_n of each vector at an observed step (δp_n is then in `dev[j].p`).
    dq_n: Vec<Sh::S<L>>,
    dd_n: Vec<Sh::S<L>>,
    /// φq_n of every lane, written by the lane loop's trajectory pass for its deviation passes.
    xs: Sh::S<L>,
    books: Vec<Renormalizer<'a>>,
    /// ln R_jj of each lane's vectors at a re-orthonormalization (lanes × K).
    logs: Vec<f64>,
    /// One vector: its Σ ln R and MEGNO per lane.
    growth: LaneGrowth<L>,
    /// One vector: the lane loop renormalizes it itself and leaves the norms here (step, the
    /// lanes' norms, the lanes due), for the next careful step to book.
    norms: Vec<(u64, L, LaneSet)>,
    /// The step the state is at, and at the checkpoint.
    at: u64,
    checkpoint_at: u64,
    active: LaneSet,
    checkpoint: Checkpoint<L, Sh>,
}

impl<'a, L: Real, Sh: Shape, P: Potential> LaneTangent<'a, L, Sh, P> {
    /// Up to `L::LANES` trajectories (lanes beyond them repeat the last and are never reported).
    fn new(sh: &'a Sh, pot: &'a P, lanes: &[Trajectory], b: &Batch<'a>) -> Self {
        let (n, count) = (sh.n(), lanes.len());
        let k = b.dq0.len() / n;
        let methods: Vec<&MethodCoefficients> = lanes.iter().map(|t| t.method).collect();
        let lane_of = |x: usize| lanes[x.min(count - 1)].q0;
        let mut st = State::<L, Sh>::new(sh);
        for i in 0..n {
            for l in 0..L::LANES {
                st.q.get_mut()[i].set_lane(l, lane_of(l)[i]);
                st.p.get_mut()[i].set_lane(l, lanes[l.min(count - 1)].p0[i]);
            }
        }
        let dev = (0..k)
            .map(|j| {
                let mut s = State::<L, Sh>::new(sh);
                for i in 0..n {
                    s.q.get_mut()[i] = L::splat(b.dq0[j * n + i]);
                    s.p.get_mut()[i] = L::splat(b.dp0[j * n + i]);
                }
                s
            })
            .collect();
        let zero = || Sh::S::<L>::filled(n, L::zero());
        let coef = Coef::new(sh, &methods);
        let growth = LaneGrowth::new(coef.h);
        let books = lanes
            .iter()
            .map(|t| {
                let request = TangentRequest {
                    n_steps: t.n_steps,
                    renormalize_every: b.renormalize_every,
                    sample_every: t.n_steps,
                };
                Renormalizer::new(k, n, b.metric, t.method.h, &request)
            })
            .collect();
        LaneTangent {
            sh,
            pot,
            ws: pot.workspace(),
            k: coef,
            w: Weights::new(sh, &vec![0.0; n], &methods),
            metric: b.metric.iter().map(|&x| L::splat(x)).collect(),
            metric_f64: b.metric,
            st,
            dev,
            dq_n: (0..k).map(|_| zero()).collect(),
            dd_n: (0..k).map(|_| zero()).collect(),
            xs: zero(),
            books,
            logs: vec![0.0; L::LANES * k],
            growth,
            norms: Vec::new(),
            at: 0,
            checkpoint_at: 0,
            active: LaneSet::first(count),
            checkpoint: (zero(), zero(), (0..k).map(|_| (zero(), zero())).collect()),
        }
    }

    /// g(φq_n) into the trajectory's state, then G(φq_n)φδq_n of every vector into its state's
    /// force row, in the bundle's arithmetic.
    fn forces(&mut self) -> CoreResult<()> {
        let phi_identity = self.k.phi_is_identity;
        recursion::evaluate(
            self.sh,
            self.pot,
            &mut self.ws,
            &self.k,
            &mut self.st,
            false,
            phi_identity,
            true,
        )?;
        let x = if phi_identity {
            self.st.q.get()
        } else {
            self.st.x.get()
        };
        let mut v = Sh::S::<L>::filled(self.sh.n(), L::zero());
        for dev in &mut self.dev {
            scaled_deviation(self.sh, &self.k, phi_identity, dev.q.get(), v.get_mut());
            self.pot
                .inline_force_derivative(x, v.get(), dev.f.get_mut());
        }
        Ok(())
    }

    /// The lanes whose trajectory or a deviation is not finite.
    fn nonfinite(&self) -> LaneSet {
        let mut bad = LaneSet::EMPTY;
        for s in std::iter::once(&self.st).chain(&self.dev) {
            for x in s.q.get() {
                bad |= x.nonfinite_lanes();
            }
        }
        bad
    }

    /// Modified Gram–Schmidt of the vectors (δq_n, δp_n) in the lanes `due`, as
    /// [`Renormalizer::renormalize`] does it for one trajectory (the other lanes' numbers are
    /// left as they are: their products are 0 and their norms 1), then each lane's log growths.
    fn renormalize(&mut self, step: u64, due: LaneSet) {
        let (n, kk) = (self.sh.n(), self.dev.len());
        let keep = |x: L, neutral: f64| {
            let mut y = x;
            for l in 0..L::LANES {
                if !due.contains(l) {
                    y.set_lane(l, neutral);
                }
            }
            y
        };
        for j in 0..kk {
            for i in 0..j {
                let r = keep(self.dot(i, j), 0.0);
                for t in 0..n {
                    let (a, b) = (self.dq_n[i].get()[t], self.dev[i].p.get()[t]);
                    let (c, d) = (self.dev[i].q.get()[t], self.dev[i].d.get()[t]);
                    self.dq_n[j].get_mut()[t] -= r * a;
                    self.dev[j].p.get_mut()[t] -= r * b;
                    self.dev[j].q.get_mut()[t] -= r * c;
                    self.dev[j].d.get_mut()[t] -= r * d;
                }
            }
            let norm = keep(self.dot(j, j).sqrt(), 1.0);
            let inv = L::splat(1.0) / norm;
            for l in due.iter() {
                self.logs[l * kk + j] = norm.lane(l).ln();
            }
            // δq_n and δp_n of the last vector are read by no later vector and returned by no
            // batch (the recursion carries δq and δd): only those two are scaled.
            let dev = &mut self.dev[j];
            let last = j + 1 == kk;
            for row in [
                dev.q.get_mut(),
                dev.d.get_mut(),
                self.dq_n[j].get_mut(),
                dev.p.get_mut(),
            ]
            .into_iter()
            .take(if last { 2 } else { 4 })
            {
                for x in row.iter_mut() {
                    *x *= inv;
                }
            }
        }
        for l in due.iter() {
            self.books[l].grown(step, &self.logs[l * kk..(l + 1) * kk]);
        }
    }

    /// Whether the lane loop renormalizes (one vector, renormalized at all).
    fn in_loop(&self) -> bool {
        self.dev.len() == 1 && self.books[0].request().renormalize_every > 0
    }

    /// Steps from `self.at` to `e` in the lane loop; `ends`: lanes also renormalized at the
    /// first step (their last). Returns what [`Stepper::hot`] returns.
    fn steps(&mut self, e: u64, ends: LaneSet) -> Option<u64> {
        let (every, ends) = if self.in_loop() {
            (self.books[0].request().renormalize_every, ends)
        } else {
            (0, LaneSet::EMPTY)
        };
        let renorm = Renorm {
            every,
            ends,
            metric: self.metric_f64,
            norms: &mut self.norms,
            dq_n: self.dq_n[0].get_mut(),
            dd_n: self.dd_n[0].get_mut(),
        };
        let (sh, pot, k, w) = (self.sh, self.pot, &self.k, &self.w);
        let (st, dev, xs) = (&mut self.st, &mut self.dev[..], &mut self.xs);
        let (n, active) = (self.at, self.active);
        let found = if k.phi_is_identity {
            lane_loop::<L, Sh, P, true>(sh, pot, k, w, st, dev, xs, renorm, active, n, e)
        } else {
            lane_loop::<L, Sh, P, false>(sh, pot, k, w, st, dev, xs, renorm, active, n, e)
        };
        self.at = e;
        found
    }

    /// ⟨v_i, v_j⟩ = Σ w_t (δq_i δq_j + δp_i δp_j), in the order of the one-trajectory sum.
    fn dot(&self, i: usize, j: usize) -> L {
        let (qi, qj) = (self.dq_n[i].get(), self.dq_n[j].get());
        let (pi, pj) = (self.dev[i].p.get(), self.dev[j].p.get());
        let mut s = L::zero();
        for t in 0..self.sh.n() {
            s += self.metric[t] * (qi[t] * qj[t] + pi[t] * pj[t]);
        }
        s
    }
}

impl<L: Real, Sh: Shape, P: Potential> Stepper for LaneTangent<'_, L, Sh, P> {
    /// The running lanes whose trajectory or a deviation is not finite after the step.
    type Observation = LaneSet;
    type Output = Vec<TangentOutput>;
    /// Four checks of the lane loop: the events (a careful step, the checkpoint, booking the
    /// norms) are then rare beside the steps; a replay costs at most this many steps.
    const SEGMENT: u64 = 4 * CHECK;

    fn active(&self) -> LaneSet {
        self.active
    }

    fn record(&self) -> Record {
        Record {
            save_every: None,
            track: false,
        }
    }

    fn n_steps(&self, b: usize) -> u64 {
        self.books[b].request().n_steps
    }

    fn own_event(&self, n: u64) -> u64 {
        match self.books[0].request().renormalize_every {
            0 => u64::MAX,
            // (One vector: renormalized inside the lane loop.)
            _ if self.in_loop() => u64::MAX,
            r => n.div_ceil(r).saturating_mul(r),
        }
    }

    fn start(&mut self) -> CoreResult<()> {
        self.forces()?;
        recursion::two_step_start(self.sh, &self.k, &mut self.st);
        for dev in &mut self.dev {
            recursion::two_step_start(self.sh, &self.k, dev);
        }
        self.at = 1;
        Ok(())
    }

    fn save_checkpoint(&mut self) {
        self.checkpoint_at = self.at;
        self.norms.clear();
        let (q, d, devs) = &mut self.checkpoint;
        q.get_mut().copy_from_slice(self.st.q.get());
        d.get_mut().copy_from_slice(self.st.d.get());
        for ((dq, dd), dev) in devs.iter_mut().zip(&self.dev) {
            dq.get_mut().copy_from_slice(dev.q.get());
            dd.get_mut().copy_from_slice(dev.d.get());
        }
    }

    fn restore_checkpoint(&mut self) -> CoreResult<()> {
        self.at = self.checkpoint_at;
        self.norms.clear();
        let (q, d, devs) = &self.checkpoint;
        self.st.q.get_mut().copy_from_slice(q.get());
        self.st.d.get_mut().copy_from_slice(d.get());
        for ((dq, dd), dev) in devs.iter().zip(&mut self.dev) {
            dev.q.get_mut().copy_from_slice(dq.get());
            dev.d.get_mut().copy_from_slice(dd.get());
        }
        Ok(())
    }

    fn hot(&mut self, n: u64, e: u64) -> CoreResult<Option<u64>> {
        debug_assert_eq!(n, self.at);
        Ok(self.steps(e, LaneSet::EMPTY))
    }

    /// One step of the lane loop, keeping δq_n and δd_n and completing δp_n.
    fn observe(&mut self) -> CoreResult<LaneSet> {
        for ((dev, dq_n), dd_n) in self.dev.iter().zip(&mut self.dq_n).zip(&mut self.dd_n) {
            dq_n.get_mut().copy_from_slice(dev.q.get());
            dd_n.get_mut().copy_from_slice(dev.d.get());
        }
        // The lanes whose last step this is are renormalized there too.
        let i = self.at;
        let mut ends = LaneSet::EMPTY;
        for l in self.active.iter() {
            ends.insert_if(l, self.books[l].request().n_steps == i);
        }
        self.steps(i + 1, ends);
        for (dev, dd_n) in self.dev.iter_mut().zip(&self.dd_n) {
            recursion::momenta_after_step(
                self.sh,
                &self.k,
                dev.d.get(),
                dd_n.get(),
                dev.p.get_mut(),
            );
        }
        Ok(self.nonfinite() & self.active)
    }

    fn nonfinite(&self, bad: &LaneSet) -> LaneSet {
        *bad & self.active
    }

    fn careful(&mut self, i: u64, bad: LaneSet, _event: bool) -> CoreResult<()> {
        let (mut due, in_loop) = (LaneSet::EMPTY, self.in_loop());
        for l in self.active.iter() {
            if bad.contains(l) {
                // q_{i+1} or δq_{i+1} is not finite, so neither is p_i or δp_i: stop at step i.
                if in_loop {
                    self.growth.sample_last(l, &mut self.books[l].out);
                }
                self.books[l].blow_up(i, "the trajectory or a deviation");
                self.active.remove(l);
                continue;
            }
            self.books[l].out.steps_done = i;
            due.insert_if(l, !in_loop && self.books[l].due(i));
        }
        if in_loop {
            // The lane loop's renormalizations since the last careful step, in order (a lane
            // not finite at i has none before i: the driver replays a segment with one).
            for (step, norm, due) in self.norms.drain(..) {
                let (due, mut logs) = (due & self.active, L::zero());
                for l in due.iter() {
                    logs.set_lane(l, norm.lane(l).ln());
                }
                self.growth.grown(step, logs, due);
            }
        } else if !due.is_empty() {
            self.renormalize(i, due);
        }
        for l in self.active.iter() {
            if i == self.books[l].request().n_steps {
                if in_loop {
                    self.growth.sample(l, i, &mut self.books[l].out);
                }
                self.active.remove(l);
            }
        }
        Ok(())
    }

    fn interrupt_at_last_observation(&mut self) {
        for l in self.active.iter() {
            let step = self.books[l].out.steps_done;
            self.books[l].interrupt(step);
        }
        self.active = LaneSet::EMPTY;
    }

    fn interrupt(&mut self, e: u64) {
        for l in self.active.iter() {
            self.books[l].interrupt(e);
        }
        self.active = LaneSet::EMPTY;
    }

    fn finish(&mut self) -> Vec<TangentOutput> {
        self.books
            .iter_mut()
            .map(|b| std::mem::replace(&mut b.out, TangentOutput::empty()))
            .collect()
    }
}

#[cfg(test)]
#[path = "tangent_lanes_tests.rs"]
mod tests;

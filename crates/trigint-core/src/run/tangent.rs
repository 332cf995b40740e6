//! The tangent step: the exact linearization of the two-step recursion (2.5) that
//! [`integrate`](super::integrate) steps, carried along its trajectory for a set of deviation
//! vectors, with Benettin's QR re-orthonormalization (Benettin, Galgani, Giorgilli, Strelcyn
//! 1980) and the MEGNO indicator of the leading vector (Cincotta, Simó 2000).
//!
//! Differentiating d_{n+1} = d_n − 2(1 − c) q_n + h²ψ g(φq_n), q_{n+1} = q_n + d_{n+1} gives the
//! same recursion on a deviation (δq, δd) with the force replaced by its derivative along φδq,
//!
//!   δd_{n+1} = δd_n − 2(1 − c) δq_n + h²ψ G(φq_n) φδq_n,   δq_{n+1} = δq_n + δd_{n+1},
//!   δp_n = (δd_{n+1} + δd_n) / (2hχ),
//!
//! G = −∇²U ([`Potential::force_derivative`]), started like (2.3) from (δq_0, δp_0). Written
//! out per coordinate as the step is: the tangent of the numbers `integrate` computes, to
//! rounding (the step's own summed form, so no second rounding path). The trajectory itself is
//! advanced by the recursion's own functions, so it is `integrate`'s bit for bit.
//!
//! The deviations' inner product is ⟨a, b⟩ = Σ_k w_k (a_k b_k) over the 2n numbers (δq, δp), the
//! metric w given by the caller (the user's Euclidean norm seen in the core's coordinates: ones
//! for a permutation or an orthogonal basis).

use super::bundle::CHECK;
use super::drive::{run, Stepper};
use super::renormalize::{check_tangent, Renormalizer, TangentOutput, TangentRequest};
use super::{check_state, uniform, Control};
use crate::coefficients::{Coef, MethodCoefficients, Weights};
use crate::error::CoreResult;
use crate::output::Record;
use crate::potential::{Potential, Scratch};
use crate::real::{LaneSet, Real, Scalar};
use crate::recursion::{self, Observe, State};
use crate::shape::{Fixed, Layout, Shape, Storage};

/// The deviation vectors (K × n each): δq and δd (at step n + 1 once a step is taken), the δp_n
/// that step completed, and δq_n.
struct Deviations {
    k: usize,
    dq: Vec<f64>,
    dd: Vec<f64>,
    dp: Vec<f64>,
    prev_q: Vec<f64>,
}

/// The tangent's own copy of the method's numbers, per coordinate (in f64 whatever the lane
/// type of the trajectory).
struct Rows {
    h: f64,
    h2: f64,
    half_h2: f64,
    inv_2h: f64,
    two_omc: Vec<f64>,
    h2_psi: Vec<f64>,
    inv_2h_chi: Vec<f64>,
    omc: Vec<f64>,
    h_chi: Vec<f64>,
    half_h2_psi: Vec<f64>,
    phi: Vec<f64>,
}

impl Rows {
    fn new(layout: &Layout, method: &MethodCoefficients) -> Self {
        let dynamic = layout.dynamic();
        let k: Coef<f64, Vec<f64>> = Coef::new(&dynamic, &[method]);
        let per = |r: &Vec<f64>| (0..dynamic.n()).map(|i| r[dynamic.coef(i)]).collect();
        Rows {
            h: k.h,
            h2: k.h2,
            half_h2: k.half_h2,
            inv_2h: k.inv_2h,
            two_omc: per(&k.two_omc),
            h2_psi: per(&k.h2_psi),
            inv_2h_chi: per(&k.inv_2h_chi),
            omc: per(&k.omc),
            h_chi: per(&k.h_chi),
            half_h2_psi: per(&k.half_h2_psi),
            phi: per(&k.phi),
        }
    }
}

/// Runs the trajectory from (q0, p0) with `k` deviation vectors (δq0, δp0 row-major, K × n, in
/// the core's coordinates), re-orthonormalized every `renormalize_every` steps in the metric
/// `metric` (n weights, applied to δq and δp alike). `control.report` is called every
/// `control.every` steps and may stop the run (status "interrupted"). A trajectory or a
/// deviation that turns non-finite ends the run ("blow-up") with what was recorded before. The
/// trajectory runs on the shape `integrate` gives it (compile-time sizes for the small uniform
/// ones, its state in registers).
#[allow(clippy::too_many_arguments)]
pub fn tangent<P: Potential>(
    pot: &P,
    layout: &Layout,
    method: &MethodCoefficients,
    q0: &[f64],
    p0: &[f64],
    dq0: &[f64],
    dp0: &[f64],
    metric: &[f64],
    request: &TangentRequest,
    control: &mut Control,
) -> CoreResult<TangentOutput> {
    layout.validate()?;
    pot.check_dim(layout.dim())?;
    let n = layout.dim();
    method.validate(n, true)?;
    check_state("q0", q0, n, "")?;
    check_state("p0", p0, n, "")?;
    let k = check_tangent(n, dq0, dp0, metric, request)?;
    let dev = Deviations {
        k,
        dq: dq0.to_vec(),
        dd: vec![0.0; k * n],
        dp: dp0.to_vec(),
        prev_q: dq0.to_vec(),
    };
    let rows = Rows::new(layout, method);
    with_shape!(layout, &[method], 1, |sh, One| {
        let mut r =
            Run::<P, One, _>::new(pot, sh, layout, method, q0, p0, dev, rows, metric, request);
        run(&mut r, control)
    })
}

struct Run<'a, P: Potential, L: Real, Sh: Shape> {
    pot: &'a P,
    sh: &'a Sh,
    k: Coef<L, Sh::S<L>>,
    /// The two-step sweep reads its weights' rows (unused when it observes nothing).
    w: Weights<L, Sh::S<L>>,
    t: Rows,
    /// q_n and d_n before the step that takes the state to n + 1 (kept where a stop can come).
    prev_q: Vec<L>,
    prev_d: Vec<L>,
    ws: P::Workspace<L>,
    ws64: P::Workspace<f64>,
    scratch: Scratch,
    st: State<L, Sh>,
    dev: Deviations,
    /// φδq of one vector and G(φq_n)φδq of the vectors.
    phi_v: Vec<f64>,
    gv: Vec<f64>,
    /// Benettin's bookkeeping and the output.
    book: Renormalizer<'a>,
    /// q, d, δq and δd at the start of the segment.
    checkpoint: (Vec<L>, Vec<L>, Vec<f64>, Vec<f64>),
    /// The ingredients of the state at the last step that passed the finite test (q_n,
    /// d_{n+1}, d_n), so that a run that blows up still returns the state at `steps_done`.
    good: Option<[Vec<L>; 3]>,
    ended: bool,
}

impl<'a, P: Potential, L: Real, Sh: Shape> Run<'a, P, L, Sh> {
    #[allow(clippy::too_many_arguments)]
    fn new(
        pot: &'a P,
        sh: &'a Sh,
        layout: &Layout,
        method: &MethodCoefficients,
        q0: &[f64],
        p0: &[f64],
        dev: Deviations,
        t: Rows,
        metric: &'a [f64],
        request: &TangentRequest,
    ) -> Self {
        let n = sh.n();
        let mut st = State::new(sh);
        for (a, b) in st.q.get_mut().iter_mut().zip(q0) {
            *a = L::splat(*b);
        }
        for (a, b) in st.p.get_mut().iter_mut().zip(p0) {
            *a = L::splat(*b);
        }
        let k = dev.k;
        let (t_h, st_q) = (t.h, st.q.get().to_vec());
        Run {
            pot,
            sh,
            k: Coef::new(sh, &[method]),
            w: Weights::new(sh, &layout.omega2, &[method]),
            t,
            prev_q: vec![L::zero(); n],
            prev_d: vec![L::zero(); n],
            ws: pot.workspace::<L>(),
            ws64: pot.workspace::<f64>(),
            scratch: Scratch::default(),
            st,
            dev,
            phi_v: vec![0.0; n],
            gv: vec![0.0; k * n],
            book: Renormalizer::new(k, n, metric, t_h, request),
            checkpoint: (st_q.clone(), st_q, vec![0.0; k * n], vec![0.0; k * n]),
            good: None,
            ended: false,
        }
    }

    /// g(φq_n) into the state (the force `integrate` evaluates, the same numbers), then
    /// G(φq_n)φδq of every vector into `gv`.
    #[inline(always)]
    fn forces(&mut self, st: &mut State<L, Sh>) -> CoreResult<()> {
        let phi_identity = self.k.phi_is_identity;
        let inline = Sh::FIXED && P::INLINE_FORCE && self.pot.inline_force_ready();
        recursion::evaluate(
            self.sh,
            self.pot,
            &mut self.ws,
            &self.k,
            st,
            false,
            phi_identity,
            inline,
        )?;
        let n = self.sh.n();
        let q = L::as_f64s(&st.q.get()[..n]).expect("one lane");
        // What the force's evaluation made of its point on the way (a wave's grid values): the
        // evaluation above is at the point G is taken at (q, or φq in the scratch x), without
        // U (`evaluate` would follow it with U at q), and not inline (which leaves nothing).
        let made = (!inline)
            .then(|| self.pot.evaluated_in_user_coordinates::<L>(&self.ws))
            .flatten();
        if phi_identity {
            for j in 0..self.dev.k {
                let r = j * n..(j + 1) * n;
                self.pot.force_derivative_after_force(
                    made,
                    q,
                    &self.dev.dq[r.clone()],
                    &mut self.gv[r],
                    &mut self.ws64,
                    &mut self.scratch,
                )?;
            }
            return Ok(());
        }
        // φq_n as `evaluate` left it in the state's scratch (q itself on the slow coordinates).
        let x = L::as_f64s(&st.x.get()[..n]).expect("one lane");
        let phi = &self.t.phi[..n];
        for j in 0..self.dev.k {
            let r = j * n..(j + 1) * n;
            let v = &self.dev.dq[r.clone()];
            for i in 0..n {
                self.phi_v[i] = phi[i] * v[i];
            }
            self.pot.force_derivative_after_force(
                made,
                x,
                &self.phi_v,
                &mut self.gv[r],
                &mut self.ws64,
                &mut self.scratch,
            )?;
        }
        Ok(())
    }

    /// (2.3) on the deviations: δd_1 = −(1 − c)δq_0 + hχ δp_0 + ½h²ψ Gφδq_0, δq_1 = δq_0 + δd_1.
    fn start_deviations(&mut self) {
        let (ns, n, t) = (self.sh.ns(), self.sh.n(), &self.t);
        for j in 0..self.dev.k {
            let r = j * n..(j + 1) * n;
            let (q, d) = (&mut self.dev.dq[r.clone()], &mut self.dev.dd[r.clone()]);
            let (p, g) = (&self.dev.dp[r.clone()], &self.gv[r]);
            for i in 0..ns {
                d[i] = t.h * p[i] + t.half_h2 * g[i];
                q[i] += d[i];
            }
            for i in ns..n {
                d[i] = -(t.omc[i] * q[i]) + t.h_chi[i] * p[i] + t.half_h2_psi[i] * g[i];
                q[i] += d[i];
            }
        }
    }

    /// One tangent step from δq_n, δd_n: δd_{n+1} and δq_{n+1}, and with `keep` (where the
    /// vectors are read: an event) δp_n, keeping δq_n. (Between events δp_n is not read: the
    /// steps there leave it out, two operations a coordinate.)
    #[inline(always)]
    fn step(&mut self, keep: bool) {
        let (ns, n, t) = (self.sh.ns(), self.sh.n(), &self.t);
        let (a, hp, inv) = (&t.two_omc[..n], &t.h2_psi[..n], &t.inv_2h_chi[..n]);
        for j in 0..self.dev.k {
            let r = j * n..(j + 1) * n;
            let (q, d, p, prev) = (
                &mut self.dev.dq[r.clone()],
                &mut self.dev.dd[r.clone()],
                &mut self.dev.dp[r.clone()],
                &mut self.dev.prev_q[r.clone()],
            );
            let g = &self.gv[r];
            if keep {
                prev.copy_from_slice(q);
            }
            for i in 0..ns {
                let next = d[i] + t.h2 * g[i];
                if keep {
                    p[i] = (next + d[i]) * t.inv_2h;
                }
                d[i] = next;
                q[i] += next;
            }
            for i in ns..n {
                let next = d[i] - a[i] * q[i] + hp[i] * g[i];
                if keep {
                    p[i] = (next + d[i]) * inv[i];
                }
                d[i] = next;
                q[i] += next;
            }
        }
    }

    /// Steps `from..to` with no event among them (no sample, stop, test or renormalization):
    /// the state moved into a local, which the compiler keeps in registers on a compile-time
    /// shape.
    #[inline(always)]
    fn quiet(&mut self, from: u64, to: u64) -> CoreResult<()> {
        let mut st = std::mem::replace(&mut self.st, State::placeholder());
        let mut r = Ok(());
        for _ in from..to {
            if let Err(e) = self.advance(&mut st, false) {
                r = Err(e);
                break;
            }
        }
        self.st = st;
        r
    }

    /// One step of the trajectory and of the deviations; `keep`: also keep (q_n, d_n) and δq_n,
    /// which an event reads.
    #[inline(always)]
    fn advance(&mut self, st: &mut State<L, Sh>, keep: bool) -> CoreResult<()> {
        self.forces(st)?;
        if keep {
            let n = self.sh.n();
            self.prev_q.copy_from_slice(&st.q.get()[..n]);
            self.prev_d.copy_from_slice(&st.d.get()[..n]);
        }
        recursion::two_step_one_block(self.sh, &self.k, &self.w, st, Observe::No, true);
        self.step(keep);
        Ok(())
    }

    fn finite(&self) -> bool {
        let n = self.sh.n();
        self.st.q.get()[..n].iter().all(|x| x.lane(0).is_finite())
            && self.dev.dq.iter().all(|x| x.is_finite())
    }

    /// The state at the last step that passed the finite test, q_n and p_n = (d_{n+1} +
    /// d_n)/(2hχ) (an observing step's numbers), or NaN when no step passed.
    fn last_good_state(&self) -> (Vec<f64>, Vec<f64>) {
        let n = self.sh.n();
        match &self.good {
            Some([q, d, prev_d]) => {
                let mut p = vec![L::zero(); n];
                recursion::momenta_after_step(self.sh, &self.k, d, prev_d, &mut p);
                (
                    q.iter().map(|x| x.lane(0)).collect(),
                    p.iter().map(|x| x.lane(0)).collect(),
                )
            }
            None => (vec![f64::NAN; n], vec![f64::NAN; n]),
        }
    }
}

/// The tangent run as a stepper of the one run loop: events at the renormalizations, at least
/// every [`CHECK`] steps (the finite test) and where the driver puts them (progress, the end).
/// Observing step i is the step i → i + 1 that completes (q_i, p_i) and (δq_i, δp_i); a
/// careful step then tests, renormalizes when due, and keeps the ingredients of the state.
impl<P: Potential, L: Real, Sh: Shape> Stepper for Run<'_, P, L, Sh> {
    /// Whether the trajectory and the deviations are finite after the observing step.
    type Observation = bool;
    type Output = TangentOutput;
    const SEGMENT: u64 = CHECK;

    fn active(&self) -> LaneSet {
        if self.ended {
            LaneSet::default()
        } else {
            LaneSet::first(1)
        }
    }

    fn record(&self) -> Record {
        Record {
            save_every: None,
            track: false,
        }
    }

    fn n_steps(&self, _b: usize) -> u64 {
        self.book.request().n_steps
    }

    fn own_event(&self, n: u64) -> u64 {
        match self.book.request().renormalize_every {
            0 => u64::MAX,
            r => n.div_ceil(r).saturating_mul(r),
        }
    }

    fn start(&mut self) -> CoreResult<()> {
        let mut st = std::mem::replace(&mut self.st, State::placeholder());
        let r = self.forces(&mut st);
        if r.is_ok() {
            recursion::two_step_start(self.sh, &self.k, &mut st);
        }
        self.st = st;
        r?;
        self.start_deviations();
        Ok(())
    }

    fn save_checkpoint(&mut self) {
        let (q, d, dq, dd) = &mut self.checkpoint;
        q.copy_from_slice(self.st.q.get());
        d.copy_from_slice(self.st.d.get());
        dq.copy_from_slice(&self.dev.dq);
        dd.copy_from_slice(&self.dev.dd);
    }

    fn restore_checkpoint(&mut self) -> CoreResult<()> {
        let (q, d, dq, dd) = &self.checkpoint;
        self.st.q.get_mut().copy_from_slice(q);
        self.st.d.get_mut().copy_from_slice(d);
        self.dev.dq.copy_from_slice(dq);
        self.dev.dd.copy_from_slice(dd);
        Ok(())
    }

    fn hot(&mut self, n: u64, e: u64) -> CoreResult<Option<u64>> {
        crate::isa::run(&mut Quiet { run: self, n, e })?;
        Ok(None)
    }

    fn observe(&mut self) -> CoreResult<bool> {
        let mut st = std::mem::replace(&mut self.st, State::placeholder());
        let advanced = self.advance(&mut st, true);
        self.st = st;
        advanced?;
        Ok(self.finite())
    }

    fn nonfinite(&self, finite: &bool) -> LaneSet {
        if *finite {
            LaneSet::default()
        } else {
            self.active()
        }
    }

    fn careful(&mut self, i: u64, finite: bool, _event: bool) -> CoreResult<()> {
        if self.ended {
            return Ok(());
        }
        if !finite {
            // q_{i+1} or δq_{i+1} is not, so neither is p_i or δp_i: the state at step i.
            self.book.blow_up(i, "the trajectory or a deviation");
            self.ended = true;
            return Ok(());
        }
        let n = self.sh.n();
        let good = self
            .good
            .get_or_insert_with(|| std::array::from_fn(|_| vec![L::zero(); n]));
        good[0].copy_from_slice(&self.prev_q);
        good[1].copy_from_slice(&self.st.d.get()[..n]);
        good[2].copy_from_slice(&self.prev_d);
        self.book.out.steps_done = i;
        if self.book.due(i) {
            let dev = &mut self.dev;
            self.book.renormalize(
                i,
                &mut dev.prev_q,
                &mut dev.dp,
                &mut [&mut dev.dq, &mut dev.dd],
            );
        }
        if i == self.book.request().n_steps {
            self.ended = true;
        }
        Ok(())
    }

    fn interrupt_at_last_observation(&mut self) {
        let step = self.book.out.steps_done;
        self.interrupt(step);
    }

    fn interrupt(&mut self, e: u64) {
        self.book.interrupt(e);
        self.ended = true;
    }

    fn finish(&mut self) -> TangentOutput {
        let (q, p) = self.last_good_state();
        let mut out = std::mem::replace(&mut self.book.out, TangentOutput::empty());
        out.q = q;
        out.p = p;
        out.dq = std::mem::take(&mut self.dev.prev_q);
        out.dp = std::mem::take(&mut self.dev.dp);
        out
    }
}

/// The steps between events ([`Run::quiet`]) as a planned loop: a copy per instruction set,
/// chosen by the planner as `integrate`'s loop is. (Compiled once for the baseline, its
/// legacy-SSE instructions ran 1.9x slower after AVX-512 code had run in the process, on an
/// Intel Xeon: 52-56 against 28 ns per FPU step in `make bench`'s per-copy table.)
struct Quiet<'r, 'a, P: Potential, L: Real, Sh: Shape> {
    run: &'r mut Run<'a, P, L, Sh>,
    n: u64,
    e: u64,
}

impl<P: Potential, L: Real, Sh: Shape> crate::isa::Kernel for Quiet<'_, '_, P, L, Sh> {
    type Output = CoreResult<()>;
    const WIDE: bool = P::SPECIALIZE;
    const AVX512: bool = P::AVX512;

    #[inline(always)]
    fn run(&mut self) -> CoreResult<()> {
        self.run.quiet(self.n, self.e)
    }

    const PLANNED: bool = true;

    fn steps(&self) -> Option<(u64, u64)> {
        Some((self.n, self.e))
    }

    fn set_steps(&mut self, n: u64, e: u64) {
        (self.n, self.e) = (n, e);
    }

    fn size(&self) -> usize {
        self.run.sh.n()
    }

    fn stops_early(out: &CoreResult<()>) -> bool {
        out.is_err()
    }
}

#[cfg(test)]
#[path = "tangent_tests.rs"]
mod tests;

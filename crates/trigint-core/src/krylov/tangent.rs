//! The tangent step of the Krylov path: the one-step form linearized along its trajectory,
//!
//!   δq_{n+1} = δq_n − (1 − c)δq_n + hχ δp_n + ½h²ψ Gδ_n,
//!   δp_{n+1} = δp_n − (1 − c)δp_n − (s²/(hχ)) δq_n + ½h(cψ/χ Gδ_n + ψ/χ Gδ_{n+1}),
//!
//! Gδ_n = G(φq_n) φδq_n, every function of h√A applied by the Lanczos method as the step applies
//! it (to the tolerance of the products: the Krylov approximation of f(A)v is the exact product
//! to that tolerance, so this is the step's derivative to it). The trajectory is the one
//! [`integrate`](super::integrate) computes, by the same [`Stepper`].

use super::{check, Force, Function, MatrixFunctions, Settings, Stepper, Stop};
use crate::error::CoreResult;
use crate::krylov::Csr;
use crate::output::{Record, Status};
use crate::potential::{Potential, Scratch};
use crate::real::LaneSet;
use crate::run::{
    check_tangent, Control, Renormalizer, Stepper as RunStepper, TangentOutput, TangentRequest,
};

/// Buffers of the force's derivative: φδq, G(x)φδq and the potential's scratch.
struct Buffers {
    v: Vec<f64>,
    gv: Vec<f64>,
    scratch: Scratch,
}

/// G(x)φδq with its three products into `out`, x = φq given.
fn derivative<P: Potential>(
    st: &mut Stepper<'_, P>,
    x: &[f64],
    dq: &[f64],
    out: &mut Force,
    b: &mut Buffers,
) -> CoreResult<Result<(), Stop>> {
    if !st.phi {
        if let Err(s) = st.product(dq, &[Function::Phi], &mut [&mut b.v])? {
            return Ok(Err(s));
        }
    } else {
        b.v.copy_from_slice(dq);
    }
    st.pot
        .force_derivative(x, &b.v, &mut b.gv, &mut st.ws, &mut b.scratch)?;
    out.value = None;
    st.product(
        &b.gv,
        &[Function::Psi, Function::PsiOverChi, Function::CPsiOverChi],
        &mut [&mut out.psi, &mut out.psi_over_chi, &mut out.c_psi_over_chi],
    )
}

/// One trajectory on the Krylov path with K deviation vectors (rows of dq0, dp0) carried by the
/// tangent step, re-orthonormalized as [`crate::run::tangent`] does (the same bookkeeping), on
/// the one run loop.
#[allow(clippy::too_many_arguments)]
pub fn tangent<P: Potential>(
    a: &Csr,
    pot: &P,
    functions: &dyn MatrixFunctions,
    h: f64,
    lanczos: Settings,
    q0: &[f64],
    p0: &[f64],
    dq0: &[f64],
    dp0: &[f64],
    metric: &[f64],
    request: &TangentRequest,
    control: &mut Control,
) -> CoreResult<TangentOutput> {
    check(a, h, lanczos, q0, p0, &NO_RECORD)?;
    pot.check_dim(a.n())?;
    let n = a.n();
    let k = check_tangent(n, dq0, dp0, metric, request)?;
    let v = || vec![0.0; n];
    let mut run = TangentRun {
        st: Stepper::new(a, pot, functions, h, lanczos),
        book: Renormalizer::new(k, n, metric, h, request),
        k,
        q: q0.to_vec(),
        p: p0.to_vec(),
        q_next: v(),
        p_next: v(),
        g: Force::new(n),
        g_next: Force::new(n),
        dq: dq0.to_vec(),
        dp: dp0.to_vec(),
        dq_next: vec![0.0; k * n],
        dp_next: vec![0.0; k * n],
        dg: (0..k).map(|_| Force::new(n)).collect(),
        dg_next: (0..k).map(|_| Force::new(n)).collect(),
        b: Buffers {
            v: v(),
            gv: v(),
            scratch: Scratch::default(),
        },
        x: v(),
        good: (v(), v()),
        ended: false,
    };
    crate::run::run(&mut run, control)
}

const NO_RECORD: Record = Record {
    save_every: None,
    track: false,
};

/// The Krylov tangent run: the trajectory (q, p, g), the vectors (δq, δp, Gδ per vector), and
/// the state at the last step tested finite.
struct TangentRun<'a, P: Potential> {
    st: Stepper<'a, P>,
    book: Renormalizer<'a>,
    k: usize,
    q: Vec<f64>,
    p: Vec<f64>,
    q_next: Vec<f64>,
    p_next: Vec<f64>,
    g: Force,
    g_next: Force,
    dq: Vec<f64>,
    dp: Vec<f64>,
    dq_next: Vec<f64>,
    dp_next: Vec<f64>,
    dg: Vec<Force>,
    dg_next: Vec<Force>,
    b: Buffers,
    /// φq of the current state (q itself when φ = 1), read by the derivatives.
    x: Vec<f64>,
    good: (Vec<f64>, Vec<f64>),
    ended: bool,
}

impl<P: Potential> TangentRun<'_, P> {
    fn n(&self) -> usize {
        self.q.len()
    }

    fn set_phi_of(&mut self, next: bool) {
        let q = if next { &self.q_next } else { &self.q };
        self.x
            .copy_from_slice(if self.st.phi { q } else { &self.st.x });
    }

    /// The derivatives Gδ of every vector at the current state.
    fn derivatives(&mut self) -> CoreResult<Result<(), Stop>> {
        let n = self.n();
        for j in 0..self.k {
            let r = j * n..(j + 1) * n;
            let dq = &self.dq[r];
            if let Err(s) = derivative(&mut self.st, &self.x, dq, &mut self.dg[j], &mut self.b)? {
                return Ok(Err(s));
            }
        }
        Ok(Ok(()))
    }

    /// One step of the trajectory and the vectors; on success the state is at the next step.
    fn advance(&mut self) -> CoreResult<Result<(), Stop>> {
        let s = &mut self.st;
        if let Err(e) = s.step(
            &self.q,
            &self.p,
            &self.g,
            &mut self.q_next,
            &mut self.p_next,
            &mut self.g_next,
        )? {
            return Ok(Err(e));
        }
        self.set_phi_of(true);
        let n = self.n();
        for j in 0..self.k {
            let r = j * n..(j + 1) * n;
            let (xs, bufs) = (&self.x, &mut self.b);
            let done = self.st.step_with(
                &self.dq[r.clone()],
                &self.dp[r.clone()],
                &self.dg[j],
                &mut self.dq_next[r.clone()],
                &mut self.dp_next[r],
                &mut self.dg_next[j],
                |s, v, out| derivative(s, xs, v, out, bufs),
            )?;
            if let Err(e) = done {
                return Ok(Err(e));
            }
        }
        std::mem::swap(&mut self.q, &mut self.q_next);
        std::mem::swap(&mut self.p, &mut self.p_next);
        std::mem::swap(&mut self.g, &mut self.g_next);
        std::mem::swap(&mut self.dq, &mut self.dq_next);
        std::mem::swap(&mut self.dp, &mut self.dp_next);
        std::mem::swap(&mut self.dg, &mut self.dg_next);
        Ok(Ok(()))
    }

    /// Ends the run: the product before step `step` did not converge (a blow-up, with the
    /// exponents of the last re-orthonormalization, as for a state that is not finite).
    fn lanczos_failure(&mut self, step: u64) {
        let lanczos = self.st.settings;
        self.book.sample_last();
        self.book.out.status = Status::BlowUp;
        self.book.out.message = format!(
            "stopped before step {step}: the Lanczos method did not reach the tolerance {:e} in {} \
             steps (take a smaller h or a larger tol)",
            lanczos.tol, lanczos.max_iterations
        );
        self.ended = true;
    }
}

/// A stepper whose every step is an event (a Krylov step costs dozens of sparse products; a
/// test and two copies are nothing beside them), so it needs no checkpoint and no tight loop.
/// Observing step i takes the step i − 1 → i (the one-step form's state is complete after it);
/// a careful step tests it, renormalizes when due and keeps it, so an interruption at i returns
/// the state and the vectors at i.
impl<P: Potential> RunStepper for TangentRun<'_, P> {
    /// Whether the step was taken (`None`: a product did not converge) and its state and
    /// vectors are finite.
    type Observation = Option<bool>;
    type Output = TangentOutput;
    const SEGMENT: u64 = 1;

    fn active(&self) -> LaneSet {
        if self.ended {
            LaneSet::default()
        } else {
            LaneSet::first(1)
        }
    }

    fn record(&self) -> Record {
        NO_RECORD
    }

    fn n_steps(&self, _b: usize) -> u64 {
        self.book.request().n_steps
    }

    fn start(&mut self) -> CoreResult<()> {
        self.good.0.copy_from_slice(&self.q);
        self.good.1.copy_from_slice(&self.p);
        let mut g = std::mem::replace(&mut self.g, Force::new(0));
        let forced = self.st.force(&self.q, &mut g);
        self.g = g;
        self.set_phi_of(false);
        if forced?.is_err() || self.derivatives()?.is_err() {
            self.lanczos_failure(1);
        }
        Ok(())
    }

    fn save_checkpoint(&mut self) {}

    fn restore_checkpoint(&mut self) -> CoreResult<()> {
        Ok(())
    }

    fn hot(&mut self, _n: u64, _e: u64) -> CoreResult<Option<u64>> {
        Ok(None)
    }

    fn observe(&mut self) -> CoreResult<Option<bool>> {
        if self.ended || self.advance()?.is_err() {
            return Ok(None);
        }
        Ok(Some(
            [&self.q, &self.p, &self.dq, &self.dp]
                .iter()
                .all(|v| v.iter().all(|x| x.is_finite())),
        ))
    }

    fn nonfinite(&self, observed: &Option<bool>) -> LaneSet {
        match observed {
            Some(false) => self.active(),
            _ => LaneSet::default(),
        }
    }

    fn careful(&mut self, i: u64, observed: Option<bool>, _event: bool) -> CoreResult<()> {
        if self.ended {
            return Ok(());
        }
        match observed {
            None => {
                self.lanczos_failure(i);
                return Ok(());
            }
            Some(false) => {
                self.book.blow_up(i, "the trajectory or a deviation");
                self.ended = true;
                return Ok(());
            }
            Some(true) => {}
        }
        self.good.0.copy_from_slice(&self.q);
        self.good.1.copy_from_slice(&self.p);
        self.book.out.steps_done = i;
        if self.book.due(i) {
            self.book
                .renormalize(i, &mut self.dq, &mut self.dp, &mut []);
            // The derivatives of the new vectors (linear in them: recomputed rather than
            // combined).
            if self.derivatives()?.is_err() {
                self.lanczos_failure(i + 1);
                return Ok(());
            }
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
        let mut out = std::mem::replace(&mut self.book.out, TangentOutput::empty());
        out.q = std::mem::take(&mut self.good.0);
        out.p = std::mem::take(&mut self.good.1);
        out.dq = std::mem::take(&mut self.dq);
        out.dp = std::mem::take(&mut self.dp);
        out
    }
}

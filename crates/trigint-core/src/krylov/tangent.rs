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
use crate::run::{check_tangent, Control, Renormalizer, TangentOutput, TangentRequest};

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
/// tangent step, re-orthonormalized as [`crate::run::tangent`] does (the same bookkeeping).
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
    let record = Record {
        save_every: None,
        track: false,
    };
    check(a, h, lanczos, q0, p0, &record)?;
    pot.check_dim(a.n())?;
    let n = a.n();
    let k = check_tangent(n, dq0, dp0, metric, request)?;
    let mut st = Stepper::new(a, pot, functions, h, lanczos);
    let mut book = Renormalizer::new(k, n, metric, h, request);
    let v = || vec![0.0; n];
    let (mut q, mut p, mut q_next, mut p_next) = (q0.to_vec(), p0.to_vec(), v(), v());
    let (mut g, mut g_next) = (Force::new(n), Force::new(n));
    let (mut dq, mut dp) = (dq0.to_vec(), dp0.to_vec());
    let (mut dq_next, mut dp_next) = (vec![0.0; k * n], vec![0.0; k * n]);
    let mut dg: Vec<Force> = (0..k).map(|_| Force::new(n)).collect();
    let mut dg_next: Vec<Force> = (0..k).map(|_| Force::new(n)).collect();
    let mut b = Buffers {
        v: v(),
        gv: v(),
        scratch: Scratch::default(),
    };
    // φq of the current state (q itself when φ = 1), read by the derivatives.
    let mut x = v();
    let lanczos_failure = |book: &mut Renormalizer, step: u64| {
        book.out.status = Status::BlowUp;
        book.out.message = format!(
            "stopped before step {step}: the Lanczos method did not reach the tolerance {:e} in {} \
             steps (take a smaller h or a larger tol)",
            lanczos.tol, lanczos.max_iterations
        );
    };
    let phi_of = |st: &Stepper<'_, P>, q: &[f64], x: &mut Vec<f64>| {
        x.copy_from_slice(if st.phi { q } else { &st.x });
    };
    let mut stopped = st.force(&q, &mut g)?.is_err();
    if !stopped {
        phi_of(&st, &q, &mut x);
        for j in 0..k {
            if derivative(&mut st, &x, &dq[j * n..(j + 1) * n], &mut dg[j], &mut b)?.is_err() {
                stopped = true;
                break;
            }
        }
    }
    if stopped {
        lanczos_failure(&mut book, 1);
    }
    let every = control.every.max(1);
    let mut step = 0;
    while !stopped && step < request.n_steps {
        step += 1;
        if st
            .step(&q, &p, &g, &mut q_next, &mut p_next, &mut g_next)?
            .is_err()
        {
            lanczos_failure(&mut book, step);
            break;
        }
        phi_of(&st, &q_next, &mut x);
        for j in 0..k {
            let r = j * n..(j + 1) * n;
            let xs = &x;
            let bufs = &mut b;
            let done = st.step_with(
                &dq[r.clone()],
                &dp[r.clone()],
                &dg[j],
                &mut dq_next[r.clone()],
                &mut dp_next[r],
                &mut dg_next[j],
                |s, v, out| derivative(s, xs, v, out, bufs),
            )?;
            if done.is_err() {
                stopped = true;
                break;
            }
        }
        if stopped {
            lanczos_failure(&mut book, step);
            break;
        }
        std::mem::swap(&mut q, &mut q_next);
        std::mem::swap(&mut p, &mut p_next);
        std::mem::swap(&mut g, &mut g_next);
        std::mem::swap(&mut dq, &mut dq_next);
        std::mem::swap(&mut dp, &mut dp_next);
        std::mem::swap(&mut dg, &mut dg_next);
        let finite = [&q, &p, &dq, &dp]
            .iter()
            .all(|v| v.iter().all(|x| x.is_finite()));
        if !finite {
            // the state before this step, swapped out just now, is the last finite one (the
            // state at `steps_done`): it is the one returned
            std::mem::swap(&mut q, &mut q_next);
            std::mem::swap(&mut p, &mut p_next);
            book.blow_up(step, "the trajectory or a deviation");
            break;
        }
        book.out.steps_done = step;
        if book.due(step) {
            book.renormalize(step, &mut dq, &mut dp, &mut []);
            // The derivatives of the new vectors (linear in them: recomputed rather than
            // combined).
            for j in 0..k {
                if derivative(&mut st, &x, &dq[j * n..(j + 1) * n], &mut dg[j], &mut b)?.is_err() {
                    stopped = true;
                    lanczos_failure(&mut book, step + 1);
                    break;
                }
            }
        }
        if step.is_multiple_of(every) && step < request.n_steps && !(control.report)(step) {
            book.interrupt(step);
            break;
        }
    }
    let mut out = book.out;
    out.q = q;
    out.p = p;
    out.dq = dq;
    out.dp = dp;
    Ok(out)
}

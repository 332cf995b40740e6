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
use super::renormalize::{check_tangent, Renormalizer, TangentOutput, TangentRequest};
use super::{check_state, Control};
use crate::coefficients::{Coef, MethodCoefficients, Weights};
use crate::energy::at;
use crate::error::CoreResult;
use crate::output::Status;
use crate::potential::{Potential, Scratch};
use crate::recursion::{self, Observe, State};
use crate::shape::{Dynamic, Layout, Shape, Storage};

/// The deviation vectors: per vector δq and δd (at step n + 1 once a step is taken), and the
/// δq_n, δp_n that step completed.
struct Deviations {
    k: usize,
    n: usize,
    dq: Vec<f64>,
    dd: Vec<f64>,
    dp: Vec<f64>,
    prev_q: Vec<f64>,
}

impl Deviations {
    fn vector(v: &mut [f64], j: usize, n: usize) -> &mut [f64] {
        &mut v[j * n..(j + 1) * n]
    }
}

/// Runs the trajectory from (q0, p0) with `k` deviation vectors (δq0, δp0 row-major, K × n, in
/// the core's coordinates), re-orthonormalized every `renormalize_every` steps in the metric
/// `metric` (n weights, applied to δq and δp alike). `control.report` is called every
/// `control.every` steps and may stop the run (status "interrupted"). A trajectory or a
/// deviation that turns non-finite ends the run ("blown_up") with what was recorded before.
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
    Run::new(
        pot,
        layout.dynamic(),
        method,
        q0,
        p0,
        dq0,
        dp0,
        metric,
        k,
        layout.omega2.clone(),
    )?
    .go(request, control)
}

struct Run<'a, P: Potential> {
    pot: &'a P,
    sh: Dynamic,
    k: Coef<f64, Vec<f64>>,
    /// The two-step sweep reads its weights' rows (unused when it observes nothing).
    w: Weights<f64, Vec<f64>>,
    /// q_n and d_n before the step that takes the state to n + 1.
    prev_q: Vec<f64>,
    prev_d: Vec<f64>,
    ws: P::Workspace<f64>,
    scratch: Scratch,
    st: State<f64, Dynamic>,
    dev: Deviations,
    metric: &'a [f64],
    /// φq_n, φδq and G(φq_n)φδq of one vector.
    x: Vec<f64>,
    phi_v: Vec<f64>,
    gv: Vec<f64>,
}

impl<'a, P: Potential> Run<'a, P> {
    #[allow(clippy::too_many_arguments)]
    fn new(
        pot: &'a P,
        sh: Dynamic,
        method: &MethodCoefficients,
        q0: &[f64],
        p0: &[f64],
        dq0: &[f64],
        dp0: &[f64],
        metric: &'a [f64],
        k: usize,
        layout_omega2: Vec<f64>,
    ) -> CoreResult<Self> {
        let n = sh.n();
        let coef = Coef::new(&sh, &[method]);
        let mut st = State::new(&sh);
        st.q.get_mut().copy_from_slice(q0);
        st.p.get_mut().copy_from_slice(p0);
        Ok(Run {
            pot,
            ws: pot.workspace::<f64>(),
            scratch: Scratch::default(),
            k: coef,
            st,
            dev: Deviations {
                k,
                n,
                dq: dq0.to_vec(),
                dd: vec![0.0; k * n],
                dp: dp0.to_vec(),
                prev_q: dq0.to_vec(),
            },
            w: Weights::new(&sh, &layout_omega2, &[method]),
            prev_q: q0.to_vec(),
            prev_d: vec![0.0; n],
            metric,
            x: vec![0.0; n],
            phi_v: vec![0.0; n],
            gv: vec![0.0; k * n],
            sh,
        })
    }

    /// g(φq_n) into the state (the force `integrate` evaluates, the same numbers), then
    /// G(φq_n)φδq of every vector into `gv`.
    #[inline(always)]
    fn forces(&mut self) -> CoreResult<()> {
        let phi_identity = self.k.phi_is_identity;
        let inline = P::INLINE_FORCE && self.pot.inline_force_ready();
        recursion::evaluate(
            &self.sh,
            self.pot,
            &mut self.ws,
            &self.k,
            &mut self.st,
            false,
            phi_identity,
            inline,
        )?;
        let n = self.sh.n();
        if phi_identity {
            for j in 0..self.dev.k {
                let r = j * n..(j + 1) * n;
                self.pot.force_derivative(
                    self.st.q.get(),
                    &self.dev.dq[r.clone()],
                    &mut self.gv[r],
                    &mut self.ws,
                    &mut self.scratch,
                )?;
            }
            return Ok(());
        }
        let ns = self.sh.ns();
        let phi = self.k.phi.get();
        let q = self.st.q.get();
        for i in 0..n {
            self.x[i] = if i < ns {
                q[i]
            } else {
                at(phi, self.sh.coef(i)) * q[i]
            };
        }
        for j in 0..self.dev.k {
            let v = Deviations::vector(&mut self.dev.dq, j, n);
            for i in 0..n {
                self.phi_v[i] = if i < ns {
                    v[i]
                } else {
                    at(phi, self.sh.coef(i)) * v[i]
                };
            }
            let gv = Deviations::vector(&mut self.gv, j, n);
            self.pot
                .force_derivative(&self.x, &self.phi_v, gv, &mut self.ws, &mut self.scratch)?;
        }
        Ok(())
    }

    /// (2.3) on the deviations: δd_1 = −(1 − c)δq_0 + hχ δp_0 + ½h²ψ Gφδq_0, δq_1 = δq_0 + δd_1.
    fn start(&mut self) {
        let (ns, n, k) = (self.sh.ns(), self.sh.n(), &self.k);
        let (omc, hchi, half) = (k.omc.get(), k.h_chi.get(), k.half_h2_psi.get());
        for j in 0..self.dev.k {
            let r = j * n..(j + 1) * n;
            let (q, d) = (&mut self.dev.dq[r.clone()], &mut self.dev.dd[r.clone()]);
            let (p, g) = (&self.dev.dp[r.clone()], &self.gv[r]);
            for i in 0..ns {
                d[i] = k.h * p[i] + k.half_h2 * g[i];
                q[i] += d[i];
            }
            for i in ns..n {
                let c = self.sh.coef(i);
                d[i] = -(at(omc, c) * q[i]) + at(hchi, c) * p[i] + at(half, c) * g[i];
                q[i] += d[i];
            }
        }
    }

    /// One tangent step from δq_n, δd_n: δd_{n+1}, δp_n and δq_{n+1}.
    fn step(&mut self) {
        let (ns, n, k) = (self.sh.ns(), self.sh.n(), &self.k);
        let (a, hp, inv) = (k.two_omc.get(), k.h2_psi.get(), k.inv_2h_chi.get());
        for j in 0..self.dev.k {
            let r = j * n..(j + 1) * n;
            let (q, d, p) = (
                &mut self.dev.dq[r.clone()],
                &mut self.dev.dd[r.clone()],
                &mut self.dev.dp[r.clone()],
            );
            let g = &self.gv[r.clone()];
            self.dev.prev_q[r].copy_from_slice(q);
            for i in 0..ns {
                let next = d[i] + k.h2 * g[i];
                p[i] = (next + d[i]) * k.inv_2h;
                d[i] = next;
                q[i] += next;
            }
            for i in ns..n {
                let c = self.sh.coef(i);
                let next = d[i] - at(a, c) * q[i] + at(hp, c) * g[i];
                p[i] = (next + d[i]) * at(inv, c);
                d[i] = next;
                q[i] += next;
            }
        }
    }

    fn go(mut self, request: &TangentRequest, control: &mut Control) -> CoreResult<TangentOutput> {
        let n = self.dev.n;
        let mut book = Renormalizer::new(self.dev.k, n, self.metric, self.k.h, request);
        self.forces()?;
        recursion::two_step_start(&self.sh, &self.k, &mut self.st);
        self.start();
        let every = control.every.max(1);
        for step in 1..=request.n_steps {
            // Step `step` → `step` + 1, which completes (q, p) and (δq, δp) at `step`.
            self.forces()?;
            // The state before the step is what a stop at this step reports.
            let reported = step == request.n_steps || step.is_multiple_of(every);
            if reported {
                self.prev_q.copy_from_slice(self.st.q.get());
                self.prev_d.copy_from_slice(self.st.d.get());
            }
            recursion::two_step(
                &self.sh,
                &self.k,
                &self.w,
                &mut self.st,
                Observe::No,
                true,
                &mut [],
            );
            self.step();
            // A NaN or an infinity never leaves the recursion: a test every CHECK steps (and
            // where the vectors are used) finds one.
            let renormalize = book.due(step);
            let test = reported || renormalize || step.is_multiple_of(CHECK);
            if test
                && !(self.st.q.get().iter().all(|x| x.is_finite())
                    && self.dev.dq.iter().all(|x| x.is_finite()))
            {
                book.blow_up(
                    step,
                    "the trajectory or a deviation (at this step or shortly before)",
                );
                break;
            }
            book.out.steps_done = step;
            if renormalize {
                let dev = &mut self.dev;
                book.renormalize(
                    step,
                    &mut dev.prev_q,
                    &mut dev.dp,
                    &mut [&mut dev.dq, &mut dev.dd],
                );
            }
            if step.is_multiple_of(every) && !(control.report)(step) {
                book.interrupt(step);
                break;
            }
        }
        // The state at the last step reached: q_n as it was, and p_n = (d_{n+1} + d_n)/(2hχ),
        // an observing step's numbers.
        let mut p = vec![0.0; n];
        if book.out.status == Status::BlowUp {
            // The last finite state is not kept (only every CHECK steps is one tested): the
            // samples before the blow-up are what the run has.
            p.fill(f64::NAN);
            self.prev_q.fill(f64::NAN);
        } else {
            recursion::momenta_after_step(&self.sh, &self.k, self.st.d.get(), &self.prev_d, &mut p);
        }
        let mut out = book.out;
        out.q = std::mem::take(&mut self.prev_q);
        out.p = p;
        out.dq = std::mem::take(&mut self.dev.prev_q);
        out.dp = std::mem::take(&mut self.dev.dp);
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use crate::potential::{
        Chain, Fpu, LinearMap, Op, Potential, Program, ProgramSpec, Scratch, Wave,
    };

    /// G(x)v against central differences of the force.
    fn check<P: Potential>(p: &P, x: &[f64], v: &[f64]) {
        let n = x.len();
        let mut ws = p.workspace::<f64>();
        let mut exact = vec![0.0; n];
        p.force_derivative(x, v, &mut exact, &mut ws, &mut Scratch::default())
            .unwrap();
        let eps = 1e-5;
        let at = |s: f64, ws: &mut P::Workspace<f64>| {
            let y: Vec<f64> = x.iter().zip(v).map(|(a, b)| a + s * b).collect();
            let mut f = vec![0.0; n];
            p.force(&y, &mut f, false, ws).unwrap();
            f
        };
        let (plus, minus) = (at(eps, &mut ws), at(-eps, &mut ws));
        let mut err: f64 = 0.0;
        let mut size: f64 = 0.0;
        for i in 0..n {
            err = err.max(((plus[i] - minus[i]) / (2.0 * eps) - exact[i]).abs());
            size = size.max(exact[i].abs());
        }
        assert!(err <= 1e-7 * size, "error {err} against {size}");
    }

    fn point(n: usize, seed: f64) -> Vec<f64> {
        (0..n)
            .map(|i| 0.3 * ((i as f64 + 1.0) * seed).sin())
            .collect()
    }

    #[test]
    fn fpu_short_long_and_mapped() {
        for m in [1, 3, 40] {
            check(
                &Fpu::new(m).unwrap(),
                &point(2 * m, 1.3),
                &point(2 * m, 0.7),
            );
        }
        // A rotation by 45° of the first two variables as the input map.
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let map = LinearMap::from_csr(2, 2, &[0, 2, 4], &[0, 1, 0, 1], &[s, s, -s, s]).unwrap();
        check(&Fpu::with_map(1, map).unwrap(), &[0.4, -0.2], &[0.3, 0.9]);
    }

    #[test]
    fn program_chain_and_wave() {
        // U = exp(x0 − x1) + x1⁴ sin(x2) / 4
        let spec = ProgramSpec {
            n_inputs: 3,
            ops: vec![
                Op::Input(0),
                Op::Input(1),
                Op::Input(2),
                Op::Sub(0, 1),
                Op::Exp(3),
                Op::Powi(1, 4),
                Op::Sin(2),
                Op::Mul(5, 6),
                Op::Const(0.25),
                Op::Mul(7, 8),
                Op::Add(4, 9),
            ],
            output: 10,
        };
        let program = Program::new(&spec, None).unwrap();
        check(&program, &[0.2, -0.4, 0.7], &[1.0, 0.5, -0.3]);
        check(&program.interpreted(), &[0.2, -0.4, 0.7], &[1.0, 0.5, -0.3]);
        let (ptr, cols, vals) = crate::fixtures::fpu_springs(5);
        let map = LinearMap::from_csr(6, 10, &ptr, &cols, &vals).unwrap();
        let chain = Chain::single(map, &Chain::monomial(0.25, 4)).unwrap();
        check(&chain, &point(10, 0.9), &point(10, 2.1));
        let quartic_sine = ProgramSpec {
            n_inputs: 1,
            ops: vec![
                Op::Input(0),
                Op::Powi(0, 4),
                Op::Const(0.25),
                Op::Mul(2, 1),
                Op::Sin(0),
                Op::Add(3, 4),
            ],
            output: 5,
        };
        for shape in [vec![16], vec![8, 6]] {
            let n: usize = shape.iter().product();
            let order: Vec<usize> = (0..n).rev().collect();
            let wave = Wave::new(&shape, &quartic_sine, order).unwrap();
            check(&wave, &point(n, 1.7), &point(n, 0.4));
        }
    }
}

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
use super::{check_state, uniform, Control};
use crate::coefficients::{Coef, MethodCoefficients, Weights};
use crate::error::CoreResult;
use crate::output::Status;
use crate::potential::{Potential, Scratch};
use crate::real::{Real, Scalar};
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
    with_shape!(layout, &[method], |sh, One| {
        Run::<P, One, _>::new(pot, sh, layout, method, q0, p0, dev, rows, metric)
            .go(request, control)
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
    metric: &'a [f64],
    /// φδq of one vector and G(φq_n)φδq of the vectors.
    phi_v: Vec<f64>,
    gv: Vec<f64>,
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
            metric,
            phi_v: vec![0.0; n],
            gv: vec![0.0; k * n],
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
        if phi_identity {
            for j in 0..self.dev.k {
                let r = j * n..(j + 1) * n;
                self.pot.force_derivative(
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
            self.pot.force_derivative(
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
    fn start(&mut self) {
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

    /// One tangent step from δq_n, δd_n: δd_{n+1}, δp_n and δq_{n+1}, keeping δq_n when `keep`
    /// (where the vectors are read: an event).
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
                p[i] = (next + d[i]) * t.inv_2h;
                d[i] = next;
                q[i] += next;
            }
            for i in ns..n {
                let next = d[i] - a[i] * q[i] + hp[i] * g[i];
                p[i] = (next + d[i]) * inv[i];
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
        recursion::two_step(self.sh, &self.k, &self.w, st, Observe::No, true, &mut []);
        self.step(keep);
        Ok(())
    }

    fn finite(&self) -> bool {
        let n = self.sh.n();
        self.st.q.get()[..n].iter().all(|x| x.lane(0).is_finite())
            && self.dev.dq.iter().all(|x| x.is_finite())
    }

    fn go(mut self, request: &TangentRequest, control: &mut Control) -> CoreResult<TangentOutput> {
        let n = self.sh.n();
        let mut book = Renormalizer::new(self.dev.k, n, self.metric, self.t.h, request);
        let mut st = std::mem::replace(&mut self.st, State::placeholder());
        self.forces(&mut st)?;
        recursion::two_step_start(self.sh, &self.k, &mut st);
        self.st = st;
        self.start();
        let every = control.every.max(1);
        let renormalize_every = match request.renormalize_every {
            0 => u64::MAX,
            r => r,
        };
        // The ingredients of the state at the last step that passed the finite test (q_n,
        // d_{n+1}, d_n), so that a run that blows up still returns the state at `steps_done`.
        let mut kept: Option<[Vec<L>; 3]> = None;
        let mut step = 1;
        while step <= request.n_steps {
            // The next step with an event: a renormalization, a test, a report, the last.
            let up = |s: u64| step.div_ceil(s).saturating_mul(s);
            let event = up(renormalize_every)
                .min(up(CHECK))
                .min(up(every))
                .min(request.n_steps);
            self.quiet(step, event)?;
            // Step `event` → `event` + 1, which completes (q, p) and (δq, δp) at `event`.
            let mut st = std::mem::replace(&mut self.st, State::placeholder());
            let advanced = self.advance(&mut st, true);
            self.st = st;
            advanced?;
            step = event;
            if !self.finite() {
                book.blow_up(
                    step,
                    "the trajectory or a deviation (at this step or shortly before)",
                );
                break;
            }
            book.out.steps_done = step;
            if request.n_steps > step {
                let k = kept.get_or_insert_with(|| std::array::from_fn(|_| vec![L::zero(); n]));
                k[0].copy_from_slice(&self.prev_q);
                k[1].copy_from_slice(&self.st.d.get()[..n]);
                k[2].copy_from_slice(&self.prev_d);
            }
            if book.due(step) {
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
            step += 1;
        }
        // The state at the last step reached (at a blow-up, the last that was tested finite):
        // q_n as it was, and p_n = (d_{n+1} + d_n)/(2hχ), an observing step's numbers.
        let mut out = book.out;
        let ingredients = if out.status == Status::BlowUp {
            kept.as_ref()
                .map(|[q, d, prev_d]| (&q[..], &d[..], &prev_d[..]))
        } else {
            Some((&self.prev_q[..], &self.st.d.get()[..n], &self.prev_d[..]))
        };
        match ingredients {
            Some((q, d, prev_d)) => {
                let mut p = vec![L::zero(); n];
                recursion::momenta_after_step(self.sh, &self.k, d, prev_d, &mut p);
                out.q = q.iter().map(|x| x.lane(0)).collect();
                out.p = p.iter().map(|x| x.lane(0)).collect();
            }
            // a blow-up before the first test: no finite state after the start
            None => {
                out.q = vec![f64::NAN; n];
                out.p = vec![f64::NAN; n];
            }
        }
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

//! The Krylov path: a large sparse stiffness matrix A (no eigenvectors stored), every matrix
//! function of h√A applied by the Lanczos method (`lanczos`), the one-step form of any method
//! (GNI XIII (2.7)–(2.9)):
//!
//!   q_{n+1} = q_n − (1 − c)q_n + hχ p_n + ½h²ψ g_n,
//!   p_{n+1} = p_n − (1 − c)p_n − (s²/(hχ)) q_n + ½h(cψ/χ g_n + ψ/χ g_{n+1}),
//!
//! g_n = g(φq_n), all functions of h√A (c = cos, s = sin of hω̃). One trajectory or many (each
//! lane on its own, on the rayon pool: a lane's bits do not depend on the batch or the threads).
//! Energies: ½|p|² + ½qᵀAq is H_ω when A has no zero eigenvalue, H_slow = U(q).

mod csr;
mod functions;
mod lanczos;
mod run;
mod tangent;
mod tridiagonal;

use std::sync::atomic::AtomicBool;

use rayon::prelude::*;

pub use csr::{dot, norm, Csr};
pub use functions::{
    Filter, Function, MatrixFunctions, Trigonometric, Values, FUNCTIONS, FUNCTION_COUNT,
};
pub use lanczos::{Lanczos, Product, MAX_ITERATIONS};
use run::KrylovRun;
pub use tangent::tangent;
pub use tridiagonal::Tridiagonal;

use crate::channels::FIRST_BLOCK;
use crate::energy::{sum, Sums};
use crate::error::{CoreError, CoreResult};
use crate::output::{Record, TrajectoryOutput};
use crate::potential::Potential;
use crate::run::{check_state, check_state_rows, Control};

/// What a Krylov run adds to its output: the Lanczos counts.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct KrylovCounts {
    pub iterations: u64,
    pub products: u64,
}

/// The main channels at a state, from the channel table's values with the sums of the whole
/// state as one block: Σ(p² + ω²q²) read as |p|² + qᵀAq (so H_ω = ½|p|² + ½qᵀAq, the one
/// block's energy, which the row repeats), no slow coordinates (H_slow = U), and NaN for the
/// modified sum (it needs the frequencies).
fn energies(a: &Csr, scratch: &mut [f64], q: &[f64], p: &[f64], u: f64) -> [f64; FIRST_BLOCK] {
    a.apply(q, scratch);
    let mut sums = Sums::zero();
    sums.0[sum::OSCILLATOR] = dot(p, p) + dot(q, scratch);
    sums.0[sum::MODIFIED] = f64::NAN;
    sums.channels(u, false)
}

/// The main channels (see `energies`) of each state (rows of `q`, `p`, n values each): what
/// `ti.energies` reports on the Krylov path, computed as a run computes them.
pub fn state_energies<P: Potential>(
    a: &Csr,
    pot: &P,
    q: &[f64],
    p: &[f64],
) -> CoreResult<Vec<[f64; FIRST_BLOCK]>> {
    let n = a.n();
    pot.check_dim(n)?;
    check_state_rows(q, p, n)?;
    let mut ws = pot.workspace::<f64>();
    let mut scratch = vec![0.0; n];
    q.chunks_exact(n)
        .zip(p.chunks_exact(n))
        .map(|(q, p)| {
            let u = pot.value(q, &mut ws)?;
            Ok(energies(a, &mut scratch, q, p, u))
        })
        .collect()
}

/// g(φq) and the products of it the steps need: ψg, (ψ/χ)g, (cψ/χ)g.
struct Force {
    psi: Vec<f64>,
    psi_over_chi: Vec<f64>,
    c_psi_over_chi: Vec<f64>,
    /// U(q), known when φ = 1 (the force pass at q computes it).
    value: Option<f64>,
}

impl Force {
    fn new(n: usize) -> Self {
        Force {
            psi: vec![0.0; n],
            psi_over_chi: vec![0.0; n],
            c_psi_over_chi: vec![0.0; n],
            value: None,
        }
    }

    fn copy_from(&mut self, other: &Force) {
        self.psi.copy_from_slice(&other.psi);
        self.psi_over_chi.copy_from_slice(&other.psi_over_chi);
        self.c_psi_over_chi.copy_from_slice(&other.c_psi_over_chi);
        self.value = other.value;
    }
}

/// Why a step could not be taken.
enum Stop {
    /// A product did not reach its tolerance.
    Lanczos,
}

/// One trajectory's stepper: its buffers and the Lanczos workspace.
struct Stepper<'a, P: Potential> {
    a: &'a Csr,
    pot: &'a P,
    f: &'a dyn MatrixFunctions,
    h: f64,
    phi: bool,
    settings: Settings,
    lz: Lanczos,
    ws: P::Workspace<f64>,
    x: Vec<f64>,
    g: Vec<f64>,
    fq: [Vec<f64>; 2],
    fp: [Vec<f64>; 2],
}

impl<'a, P: Potential> Stepper<'a, P> {
    fn new(a: &'a Csr, pot: &'a P, f: &'a dyn MatrixFunctions, h: f64, lanczos: Settings) -> Self {
        let n = a.n();
        let v = || vec![0.0; n];
        Stepper {
            a,
            pot,
            f,
            h,
            phi: f.phi_is_identity(),
            settings: lanczos,
            lz: Lanczos::new(n, lanczos.tol, lanczos.max_iterations),
            ws: pot.workspace::<f64>(),
            x: v(),
            g: v(),
            fq: [v(), v()],
            fp: [v(), v()],
        }
    }

    fn product(
        &mut self,
        v: &[f64],
        which: &[Function],
        out: &mut [&mut [f64]],
    ) -> CoreResult<Result<(), Stop>> {
        Ok(match self.lz.apply(self.a, v, self.f, which, out)? {
            Product::Converged(_) => Ok(()),
            Product::NotConverged => Err(Stop::Lanczos),
        })
    }

    /// g(φq) into `out` with its three products.
    fn force(&mut self, q: &[f64], out: &mut Force) -> CoreResult<Result<(), Stop>> {
        let u = if self.phi {
            Some(self.pot.force(q, &mut self.g, true, &mut self.ws)?)
        } else {
            let mut x = std::mem::take(&mut self.x);
            let r = self.product(q, &[Function::Phi], &mut [&mut x]);
            self.x = x;
            if let Err(s) = r? {
                return Ok(Err(s));
            }
            self.pot.force(&self.x, &mut self.g, false, &mut self.ws)?;
            None
        };
        out.value = u;
        let g = std::mem::take(&mut self.g);
        let r = self.product(
            &g,
            &[Function::Psi, Function::PsiOverChi, Function::CPsiOverChi],
            &mut [&mut out.psi, &mut out.psi_over_chi, &mut out.c_psi_over_chi],
        );
        self.g = g;
        r
    }

    /// One step from (q, p, g) into (q_next, p_next, g_next).
    #[allow(clippy::too_many_arguments)]
    fn step(
        &mut self,
        q: &[f64],
        p: &[f64],
        g: &Force,
        q_next: &mut [f64],
        p_next: &mut [f64],
        g_next: &mut Force,
    ) -> CoreResult<Result<(), Stop>> {
        self.step_with(q, p, g, q_next, p_next, g_next, |s, q, out| s.force(q, out))
    }

    /// [`step`](Self::step) with the force at q_next given by `force` (the tangent step passes
    /// the force's derivative along a deviation: the step is linear in everything else).
    #[allow(clippy::too_many_arguments)]
    fn step_with(
        &mut self,
        q: &[f64],
        p: &[f64],
        g: &Force,
        q_next: &mut [f64],
        p_next: &mut [f64],
        g_next: &mut Force,
        mut force: impl FnMut(&mut Self, &[f64], &mut Force) -> CoreResult<Result<(), Stop>>,
    ) -> CoreResult<Result<(), Stop>> {
        let h = self.h;
        let (mut fq, mut fp) = (std::mem::take(&mut self.fq), std::mem::take(&mut self.fp));
        let r = (|| -> CoreResult<Result<(), Stop>> {
            let [a, b] = &mut fq;
            if let Err(s) = self.product(
                q,
                &[Function::OneMinusCos, Function::Sin2OverHChi],
                &mut [a, b],
            )? {
                return Ok(Err(s));
            }
            let [a, b] = &mut fp;
            if let Err(s) = self.product(p, &[Function::OneMinusCos, Function::Chi], &mut [a, b])? {
                return Ok(Err(s));
            }
            let half_h2 = 0.5 * h * h;
            for i in 0..q.len() {
                q_next[i] = q[i] - fq[0][i] + h * fp[1][i] + half_h2 * g.psi[i];
            }
            if let Err(s) = force(self, q_next, g_next)? {
                return Ok(Err(s));
            }
            let half_h = 0.5 * h;
            for i in 0..q.len() {
                p_next[i] = p[i] - fp[0][i] - fq[1][i]
                    + half_h * (g.c_psi_over_chi[i] + g_next.psi_over_chi[i]);
            }
            Ok(Ok(()))
        })();
        self.fq = fq;
        self.fp = fp;
        r
    }

    /// U(q) where the force pass did not give it.
    fn value(&mut self, q: &[f64], known: Option<f64>) -> CoreResult<f64> {
        match known {
            Some(u) => Ok(u),
            None => self.pot.value(q, &mut self.ws),
        }
    }
}

/// The Lanczos method's stopping rule: the relative tolerance of every product and the most
/// steps for one product.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    pub tol: f64,
    pub max_iterations: usize,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            tol: 1e-12,
            max_iterations: MAX_ITERATIONS,
        }
    }
}

fn check(
    a: &Csr,
    h: f64,
    lanczos: Settings,
    q0: &[f64],
    p0: &[f64],
    record: &Record,
) -> CoreResult<()> {
    let n = a.n();
    check_state("q0", q0, n, "")?;
    check_state("p0", p0, n, "")?;
    if !(h > 0.0 && h.is_finite()) {
        return Err(CoreError::invalid(
            "h",
            format!("must be finite and > 0, got {h}"),
        ));
    }
    let tol = lanczos.tol;
    if !(tol > 0.0 && tol < 1.0) {
        return Err(CoreError::invalid(
            "tol",
            format!("must be in (0, 1), got {tol}"),
        ));
    }
    if lanczos.max_iterations == 0 {
        return Err(CoreError::invalid("max_iterations", "must be >= 1"));
    }
    if record.save_every == Some(0) {
        return Err(CoreError::invalid("save_every", "must be >= 1"));
    }
    Ok(())
}

/// Integrates one trajectory on the Krylov path (see the module) for `n_steps` steps of size
/// `h`, the functions of h√A given by `functions`; `control.report(step)` is called every
/// `control.every` steps and may stop the run.
#[allow(clippy::too_many_arguments)]
pub fn integrate<P: Potential>(
    a: &Csr,
    pot: &P,
    functions: &dyn MatrixFunctions,
    h: f64,
    lanczos: Settings,
    q0: &[f64],
    p0: &[f64],
    n_steps: u64,
    record: Record,
    control: &mut Control,
) -> CoreResult<(TrajectoryOutput, KrylovCounts)> {
    check(a, h, lanczos, q0, p0, &record)?;
    pot.check_dim(a.n())?;
    let mut run = KrylovRun::new(
        Stepper::new(a, pot, functions, h, lanczos),
        q0,
        p0,
        n_steps,
        record,
    );
    let out = crate::run::run(&mut run, control)?;
    let counts = KrylovCounts {
        iterations: run.step.lz.iterations,
        products: run.step.lz.products,
    };
    Ok((
        out.into_iter().next().expect("one lane, one output"),
        counts,
    ))
}

/// Integrates many trajectories of one Krylov problem in parallel on the current rayon pool,
/// each with its own functions (its own step size `hs[t]`), initial values (row-major, B × n)
/// and step count; trajectory t gets exactly the numbers of [`integrate`] on it alone. `stop` is
/// polled every `poll` steps; once set, unfinished trajectories end "interrupted".
#[allow(clippy::too_many_arguments)]
pub fn integrate_batch<P: Potential>(
    a: &Csr,
    pot: &P,
    functions: &[&dyn MatrixFunctions],
    hs: &[f64],
    lanczos: Settings,
    q0: &[f64],
    p0: &[f64],
    n_steps: &[u64],
    record: Record,
    stop: &AtomicBool,
    poll: u64,
) -> CoreResult<Vec<(TrajectoryOutput, KrylovCounts)>> {
    let (n, count) = (a.n(), hs.len());
    if count == 0 {
        return Err(CoreError::invalid("q0", "the batch is empty"));
    }
    if functions.len() != count
        || n_steps.len() != count
        || q0.len() != count * n
        || p0.len() != count * n
    {
        return Err(CoreError::invalid(
            "q0",
            format!(
                "{count} step sizes, {} method functions, {} step counts and {} + {} initial values: \
                 expected one of each per trajectory ({n} values each)",
                functions.len(),
                n_steps.len(),
                q0.len(),
                p0.len()
            ),
        ));
    }
    (0..count)
        .into_par_iter()
        .map(|t| {
            let rows = t * n..(t + 1) * n;
            let (q, p) = (&q0[rows.clone()], &p0[rows]);
            Control::polling(stop, poll, |control| {
                integrate(
                    a,
                    pot,
                    functions[t],
                    hs[t],
                    lanczos,
                    q,
                    p,
                    n_steps[t],
                    record,
                    control,
                )
            })
            .map_err(|e| match e {
                CoreError::InvalidArgument { name, reason } => {
                    CoreError::invalid(name, format!("trajectory {t}: {reason}"))
                }
                other => other,
            })
        })
        .collect()
}

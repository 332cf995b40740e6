//! The entry points: [`integrate`] (one trajectory; [`integrate_prepared`] with a layout and a
//! method made once for many runs) and [`integrate_batch`] (many, in bundles of lanes on a
//! rayon pool). Both validate, choose the shape (compile-time sizes for small
//! problems) and the instruction set, and run [`Bundle`]s: one run loop for both.
//!
//! The run loop: `drive` (the `Stepper` trait and the driver from event to event, with
//! checkpoints and replay), `record` (what a careful step records: the one record policy),
//! `bundle` (the recursion's stepper), `hot` and `lanes` (its tight loops).

use std::sync::atomic::AtomicBool;

use rayon::prelude::*;

mod bundle;
mod drive;
mod hot;
mod lanes;
mod observe;
mod record;
mod renormalize;
pub(crate) use renormalize::{check_tangent, Renormalizer};
pub use renormalize::{TangentOutput, TangentRequest};

use crate::coefficients::MethodCoefficients;
use crate::error::{CoreError, CoreResult};
use crate::output::{Form, Record, TrajectoryOutput};
use crate::potential::Potential;
use crate::prepared::{PreparedLayout, PreparedMethod};
use crate::real::{Real, Scalar};
use crate::shape::{Fixed, Layout};
pub(crate) use bundle::Lane;
pub use bundle::{rows, Bundle, Rows};
pub use drive::Control;
pub(crate) use drive::{run, Stepper};
pub use observe::state_energies;
pub(crate) use record::{finish, Good, LaneBook};

/// Whether the oscillatory coordinates share one frequency and one set of method numbers in
/// every trajectory (what a [`Fixed`] shape assumes).
fn uniform(layout: &Layout, methods: &[&MethodCoefficients]) -> bool {
    let fast = layout.n_slow..layout.dim();
    let same = |v: &[f64]| v[fast.clone()].windows(2).all(|w| w[0] == w[1]);
    same(&layout.omega2)
        && methods
            .iter()
            .all(|m| m.rows().iter().all(|(_, v)| same(v)))
}

/// Runs `$body` with `$sh` bound to the layout's shape and `$one` to the number type of a
/// single trajectory on it: a compile-time [`Fixed`] shape for the small one-block arrangements
/// whose block is uniform (the state then lives in registers, in [`Scalar`]s that keep the
/// coordinates' chains apart), else a run-time shape, [`Uniform`](crate::shape::Uniform) or
/// [`Dynamic`](crate::shape::Dynamic) (in `f64`, whose loops over the coordinates vectorize). `Scalar` and `f64` do the same IEEE operations: the same bits.
///
/// `$lanes` (a constant: 1, or `L::LANES` for bundles of `L`): only one lane takes the uniform
/// shape. A bundle of several lanes takes the general run-time shape: each coordinate's
/// numbers, read once, serve all its lanes, and that measured as fast untracked and 10–33%
/// faster with energies streamed (ensembles of FPU m = 30 and 1000, a chain of 1000 springs,
/// a compiled FPU m = 30; AMD Zen 3, AVX2), while the uniform shape's copies of the kernels
/// were a quarter of the tight loops' machine code. Both shapes read the same numbers: the
/// same bits.
macro_rules! with_shape {
    ($layout:expr, $methods:expr, $lanes:expr, |$sh:ident, $one:ident| $body:expr) => {{
        let lay: &Layout = $layout;
        // Each condition starts with the potential's constant, alone: the compiler then drops
        // the arms a potential does not want before building them (a chain, a wave equation or
        // a Python callback has no copies of the kernels on compile-time shapes; a Python
        // callback none on the uniform shape), as `isa::run_copy` does for instruction sets.
        // (A pair form, such as a wave equation's momentum, is never on a compile-time shape:
        // the tight loop then knows at compile time that it has none.)
        let small = |dim: usize, n_slow: usize| {
            lay.dim() == dim
                && lay.n_slow == n_slow
                && lay.pair_forms.is_none()
                && lay.n_blocks() <= 1
                && uniform(lay, $methods)
        };
        macro_rules! fixed {
            ($n:literal, $ns:literal) => {{
                let $sh = &Fixed::<$n, $ns>::new();
                #[allow(dead_code)]
                type $one = Scalar;
                $body
            }};
        }
        // m = 1 and m = 3 of the FPU chain (the paper's problem): each shape is a set of kernel
        // copies to build, so only the sizes people run for billions of steps.
        if P::SMALL_SHAPES && P::SPECIALIZE && small(2, 1) {
            fixed!(2, 1)
        } else if P::SMALL_SHAPES && P::SPECIALIZE && small(6, 3) {
            fixed!(6, 3)
        } else if P::SPECIALIZE
            && const { $lanes == 1 }
            && lay.n_blocks() <= 1
            && uniform(lay, $methods)
        {
            let $sh = &lay.uniform();
            #[allow(dead_code)]
            type $one = f64;
            $body
        } else {
            let $sh = &lay.dynamic();
            #[allow(dead_code)]
            type $one = f64;
            $body
        }
    }};
}

// After `with_shape!`, which it uses.
pub mod tangent;
mod tangent_lanes;
mod tangent_loop;
pub use tangent_lanes::tangent_batch;

/// A state of `n` finite numbers, or the error that names it (`which`: which trajectory).
pub(crate) fn check_state(name: &'static str, v: &[f64], n: usize, which: &str) -> CoreResult<()> {
    if v.len() != n {
        return Err(CoreError::invalid(
            name,
            format!("{which}has {} entries for {n} coordinates", v.len()),
        ));
    }
    // Whole chunks tested without an early exit (a loop the compiler vectorizes, which a search
    // that stops at the first bad entry is not), then that entry found.
    let finite = v
        .chunks(64)
        .all(|c| c.iter().fold(true, |ok, x| ok & x.is_finite()));
    if let Some(i) = (!finite)
        .then(|| v.iter().position(|x| !x.is_finite()))
        .flatten()
    {
        return Err(CoreError::invalid(
            name,
            format!("{which}entry {i} is not finite ({})", v[i]),
        ));
    }
    Ok(())
}

/// States given as rows: q and p hold rows of n numbers each, as many of both (what
/// `state_energies` of either path takes).
pub(crate) fn check_state_rows(q: &[f64], p: &[f64], n: usize) -> CoreResult<()> {
    if q.len() != p.len() || !q.len().is_multiple_of(n.max(1)) {
        return Err(CoreError::invalid(
            "q",
            format!(
                "{} positions and {} momenta: expected rows of {n} values each, as many of both",
                q.len(),
                p.len()
            ),
        ));
    }
    Ok(())
}

fn check_common<P: Potential>(pot: &P, layout: &Layout, record: &Record) -> CoreResult<()> {
    layout.validate()?;
    check_run(pot, layout, record)
}

/// The checks of a run beside the layout's own.
fn check_run<P: Potential>(pot: &P, layout: &Layout, record: &Record) -> CoreResult<()> {
    pot.check_dim(layout.dim())?;
    if record.save_every == Some(0) {
        return Err(CoreError::invalid("save_every", "must be >= 1"));
    }
    Ok(())
}

/// Checks a batch: each trajectory's method numbers (two-step form or not), initial values
/// (row-major, B × n) and step count.
pub(crate) fn check_batch(
    n: usize,
    methods: &[MethodCoefficients],
    q0: &[f64],
    p0: &[f64],
    n_steps: &[u64],
    two_step: bool,
) -> CoreResult<()> {
    let count = methods.len();
    if count == 0 {
        return Err(CoreError::invalid("q0", "the batch is empty"));
    }
    for (t, m) in methods.iter().enumerate() {
        m.validate(n, two_step)
            .map_err(|e| CoreError::invalid("coefficients", format!("trajectory {t}: {e}")))?;
    }
    for (name, v) in [("q0", q0), ("p0", p0)] {
        if v.len() != count * n {
            return Err(CoreError::invalid(
                name,
                format!("expected {count} x {n} values, got {}", v.len()),
            ));
        }
        for t in 0..count {
            check_state(
                name,
                &v[t * n..(t + 1) * n],
                n,
                &format!("trajectory {t}: "),
            )?;
        }
    }
    if n_steps.len() != count {
        return Err(CoreError::invalid(
            "n_steps",
            format!("expected {count} step counts, got {}", n_steps.len()),
        ));
    }
    if let Some(t) = n_steps.iter().position(|&s| s == 0) {
        return Err(CoreError::invalid(
            "n_steps",
            format!("trajectory {t}: must be >= 1"),
        ));
    }
    Ok(())
}

/// Integrates one trajectory of q'' + Ω²q = g(q) from (q0, p0), in the layout's coordinate
/// order, with the method's per-coordinate numbers. `control.report(step)` is called every
/// `control.every` steps and may stop the run.
#[allow(clippy::too_many_arguments)]
pub fn integrate<P: Potential>(
    pot: &P,
    layout: &Layout,
    method: &MethodCoefficients,
    q0: &[f64],
    p0: &[f64],
    n_steps: u64,
    form: Form,
    record: Record,
    control: Control,
) -> CoreResult<TrajectoryOutput> {
    check_common(pot, layout, &record)?;
    method.validate(layout.dim(), form == Form::TwoStep)?;
    one_trajectory(
        pot, layout, None, method, q0, p0, n_steps, form, record, control, false,
    )
}

/// [`integrate`] with a layout and a method made once for many runs: their checks pass once,
/// and the kernels' rows made from the method are kept for the next run (the same numbers).
/// `q_from_grid`: keep the samples' q in the user's coordinates where the potential's
/// evaluation made them ([`Bundle::with_q_from_grid`]; rows marked in
/// [`Samples::q_in_user`](crate::energy::Samples::q_in_user)).
#[allow(clippy::too_many_arguments)]
pub fn integrate_prepared<P: Potential>(
    pot: &P,
    layout: &PreparedLayout,
    method: &PreparedMethod,
    q0: &[f64],
    p0: &[f64],
    n_steps: u64,
    form: Form,
    record: Record,
    control: Control,
    q_from_grid: bool,
) -> CoreResult<TrajectoryOutput> {
    layout.validate()?;
    check_run(pot, layout, &record)?;
    method.validate(layout.dim(), form == Form::TwoStep)?;
    one_trajectory(
        pot,
        layout,
        Some((layout, method)),
        method,
        q0,
        p0,
        n_steps,
        form,
        record,
        control,
        q_from_grid,
    )
}

/// One checked trajectory, with the kernel rows and energy weights kept by a `prepared` method
/// (for its layout), or made for this run.
#[allow(clippy::too_many_arguments)]
fn one_trajectory<P: Potential>(
    pot: &P,
    layout: &Layout,
    prepared: Option<(&PreparedLayout, &PreparedMethod)>,
    method: &MethodCoefficients,
    q0: &[f64],
    p0: &[f64],
    n_steps: u64,
    form: Form,
    record: Record,
    control: Control,
    q_from_grid: bool,
) -> CoreResult<TrajectoryOutput> {
    let n = layout.dim();
    check_state("q0", q0, n, "")?;
    check_state("p0", p0, n, "")?;
    if n_steps == 0 {
        return Err(CoreError::invalid("n_steps", "must be >= 1"));
    }
    let out = with_shape!(layout, &[method], 1, |sh, One| {
        let bundle = Bundle::<One, _, P>::new(
            sh,
            pot,
            form,
            record,
            match prepared {
                Some((lay, m)) => (m.coef(sh), m.weights(sh, lay)),
                None => rows(sh, &layout.omega2, &[method]),
            },
            &[method],
            &[q0],
            &[p0],
            &[n_steps],
        )
        .with_pair_forms(layout.pair_forms.as_ref())
        .with_q_from_grid(q_from_grid);
        let mut control = control;
        bundle.run(&mut control)
    })?;
    Ok(out.into_iter().next().expect("one lane, one output"))
}

/// Integrates many trajectories of one problem, each with its own method numbers (its own step
/// size), initial values (row-major, B × n) and step count, in bundles of `L::LANES` lanes run
/// in parallel on the current rayon pool. Each trajectory gets exactly the numbers of
/// [`integrate`] on it alone: the bundles run the same code, lane by lane, whatever the bundle
/// composition or the thread count. `stop` is polled every `poll` steps; once set, unfinished
/// trajectories end "interrupted".
#[allow(clippy::too_many_arguments)]
pub fn integrate_batch<L: Real, P: Potential>(
    pot: &P,
    layout: &Layout,
    methods: &[MethodCoefficients],
    q0: &[f64],
    p0: &[f64],
    n_steps: &[u64],
    form: Form,
    record: Record,
    stop: &AtomicBool,
    poll: u64,
) -> CoreResult<Vec<TrajectoryOutput>> {
    check_common(pot, layout, &record)?;
    check_batch(
        layout.dim(),
        methods,
        q0,
        p0,
        n_steps,
        form == Form::TwoStep,
    )?;
    let n = layout.dim();
    let count = methods.len();
    // Neighbours in step count share a bundle, so few lanes idle while others finish.
    let mut order: Vec<usize> = (0..count).collect();
    order.sort_by_key(|&t| n_steps[t]);
    let bundles: Vec<&[usize]> = order.chunks(L::LANES).collect();
    let all: Vec<&MethodCoefficients> = methods.iter().collect();
    let results: Vec<CoreResult<Vec<TrajectoryOutput>>> =
        with_shape!(layout, &all, L::LANES, |sh, _One| {
            bundles
                .par_iter()
                .map(|ids| {
                    let m: Vec<&MethodCoefficients> = ids.iter().map(|&t| &methods[t]).collect();
                    let q: Vec<&[f64]> = ids.iter().map(|&t| &q0[t * n..(t + 1) * n]).collect();
                    let p: Vec<&[f64]> = ids.iter().map(|&t| &p0[t * n..(t + 1) * n]).collect();
                    let s: Vec<u64> = ids.iter().map(|&t| n_steps[t]).collect();
                    let rows = rows(sh, &layout.omega2, &m);
                    let bundle =
                        Bundle::<L, _, P>::new(sh, pot, form, record, rows, &m, &q, &p, &s)
                            .with_pair_forms(layout.pair_forms.as_ref());
                    Control::polling(stop, poll, |control| bundle.run(control))
                })
                .collect()
        });
    let mut out: Vec<Option<TrajectoryOutput>> = vec![None; count];
    for (ids, result) in bundles.iter().zip(results) {
        for (&t, r) in ids.iter().zip(result?) {
            out[t] = Some(r);
        }
    }
    Ok(out
        .into_iter()
        .map(|r| r.expect("every trajectory belongs to one bundle"))
        .collect())
}

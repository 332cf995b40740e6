//! The PyO3 binding of trigint-core: converts typed inputs, releases the interpreter lock
//! around the core, and maps core errors to Python exceptions. No numerics live here.

mod convert;
mod coordinates;
mod grid;
mod handle;
mod krylov;
mod potential;
mod result;
mod tangent;
mod watch;

use std::sync::atomic::AtomicBool;

use numpy::{PyArray1, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};
use trigint_core::{
    channel_count, channel_names, BatchLanes, Control, CoreError, Lanes, MethodCoefficients,
    TrajectoryOutput, CHANNELS,
};

use potential::{to_2d, with_potential, NativePotential};

use result::RunResult;

/// Big blocks freed by one call kept for the next (a 2^16-point wave call allocates about forty
/// of 512 KiB; faulting them in again cost a third of a short call): see `trigint_core::recycle`.
#[global_allocator]
static ALLOCATOR: trigint_core::recycle::Recycling = trigint_core::recycle::Recycling::new();

/// Core errors become Python exceptions here and nowhere else.
fn to_py(e: CoreError, pot: &NativePotential) -> PyErr {
    if let Some(original) = pot.take_error() {
        return original;
    }
    match e {
        CoreError::InvalidArgument { .. } | CoreError::DimensionMismatch { .. } => {
            PyValueError::new_err(e.to_string())
        }
        CoreError::Potential(_) | CoreError::Interrupted => PyRuntimeError::new_err(e.to_string()),
    }
}

/// integrate(potential, layout, method, q0, p0, n_steps, save_every, form, track,
/// progress_every, progress=None, q_from_grid=False) -> RunResult
///
/// `progress(steps_done)` is called every `progress_every` steps and may return False to stop;
/// Ctrl-C also stops the run, which then reports "interrupted" with its samples.
/// `q_from_grid`: samples whose q the potential's evaluation made in the user's coordinates (a
/// wave's grid values, φ = 1) keep them; `samples[0]["q_in_user"]` marks those rows.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (potential, layout, method, q0, p0, n_steps, save_every, form, track, progress_every, progress=None, q_from_grid=false))]
fn integrate<'py>(
    py: Python<'py>,
    potential: &Bound<'py, PyAny>,
    layout: &Bound<'py, PyAny>,
    method: &Bound<'py, PyAny>,
    q0: PyReadonlyArray1<f64>,
    p0: PyReadonlyArray1<f64>,
    n_steps: u64,
    save_every: u64,
    form: &str,
    track: bool,
    progress_every: u64,
    progress: Option<Py<PyAny>>,
    q_from_grid: bool,
) -> PyResult<RunResult> {
    let given = handle::given(potential)?;
    let pot = given.get();
    let given_layout = handle::given_layout(layout)?;
    let lay = given_layout.get();
    let given_method = handle::given_method(method)?;
    let co = given_method.get();
    let form = convert::form(form)?;
    let record = convert::record(Some(save_every), track);
    let (q0, p0) = (convert::vec1(q0), convert::vec1(p0));
    let mut pending: Option<PyErr> = None;
    let out: Result<TrajectoryOutput, CoreError> = {
        let mut report = watch::reporter(&progress, &mut pending);
        py.detach(|| {
            let control = Control {
                every: progress_every.max(1),
                report: &mut report,
            };
            with_potential!(pot, |p| trigint_core::integrate_prepared(
                p,
                lay,
                co,
                &q0,
                &p0,
                n_steps,
                form,
                record,
                control,
                q_from_grid
            ))
        })
    };
    let out = out.map_err(|e| to_py(e, pot))?;
    let interrupted = out.status == trigint_core::Status::Interrupted;
    result::from_outputs(
        py,
        vec![out],
        q0.len(),
        channel_count(lay.n_blocks(), lay.n_axes()),
        true,
        interrupted,
        pending.map(|e| e.to_string()),
    )
}

/// Trajectories per bundle for a vectorized Python potential: one call per bundle and step, so
/// as many as a bundle holds (a NumPy call costs tens of µs whatever its rows: 64 rows of the
/// FPU cost 1.5 µs per row, 256 rows 0.8 µs).
type WideLanes = Lanes<{ trigint_core::MAX_LANES }>;

/// Stack of each worker thread: a bundle of `WideLanes` keeps its state (2 KiB per number) in
/// locals of the step loop.
const WORKER_STACK: usize = 64 << 20;

/// Runs `body` on a rayon pool of `threads` workers (None: all cores) while this thread watches
/// for Ctrl-C, which sets `stop`. Returns the body's output and whether Ctrl-C came.
pub(crate) fn on_pool<T: Send>(
    py: Python<'_>,
    pot: &NativePotential,
    threads: Option<usize>,
    stop: &AtomicBool,
    body: impl Fn() -> Result<T, CoreError> + Send + Sync,
) -> PyResult<(T, bool)> {
    let calls_python = matches!(pot, NativePotential::Python(_));
    // A worker that calls Python keeps one interpreter thread state for the whole batch: without
    // it every call would create and delete one (with its frame stack, an mmap and munmap).
    let worker = |thread: rayon::ThreadBuilder| {
        if calls_python {
            Python::attach(|py| py.detach(|| thread.run()))
        } else {
            thread.run()
        }
    };
    let run = || {
        let mut builder = rayon::ThreadPoolBuilder::new().stack_size(WORKER_STACK);
        if let Some(t) = threads {
            builder = builder.num_threads(t);
        }
        // Scoped: the workers are joined (and their thread states deleted) before this returns.
        builder.build_scoped(worker, |pool: &rayon::ThreadPool| pool.install(&body))
    };
    let (out, interrupted) = watch::watching_ctrl_c(py, stop, run);
    match out {
        Ok(Ok(Ok(o))) => Ok((o, interrupted)),
        Ok(Ok(Err(e))) => Err(to_py(e, pot)),
        Ok(Err(e)) => Err(PyRuntimeError::new_err(format!(
            "could not start threads: {e}"
        ))),
        Err(_) => Err(PyRuntimeError::new_err("the batch worker panicked")),
    }
}

/// integrate_batch(potential, layout, methods, q0, p0, n_steps, save_every, form, track,
/// threads=None) -> RunResult
///
/// Runs the batched kernel on a pool of `threads` (None: all cores) while this thread watches
/// for Ctrl-C; on Ctrl-C the unfinished trajectories end "interrupted" and `interrupted` says so.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (potential, layout, methods, q0, p0, n_steps, save_every, form, track, threads=None))]
fn integrate_batch<'py>(
    py: Python<'py>,
    potential: &Bound<'py, PyAny>,
    layout: &Bound<'py, PyAny>,
    methods: &Bound<'py, PyDict>,
    q0: PyReadonlyArray2<f64>,
    p0: PyReadonlyArray2<f64>,
    n_steps: Vec<u64>,
    save_every: Option<u64>,
    form: &str,
    track: bool,
    threads: Option<usize>,
) -> PyResult<RunResult> {
    let given = handle::given(potential)?;
    let pot = given.get();
    let given_layout = handle::given_layout(layout)?;
    let lay = given_layout.get();
    let methods = convert::methods(methods)?;
    let form = convert::form(form)?;
    let record = convert::record(save_every, track);
    let n = lay.dim();
    let (q0, p0): (Vec<f64>, Vec<f64>) = (
        q0.as_array().iter().copied().collect(),
        p0.as_array().iter().copied().collect(),
    );
    let stop = AtomicBool::new(false);
    let (out, interrupted) = on_pool(py, pot, threads, &stop, || match pot {
        NativePotential::Python(p) if p.vectorized() => {
            trigint_core::integrate_batch::<WideLanes, _>(
                p, lay, &methods, &q0, &p0, &n_steps, form, record, &stop, 1024,
            )
        }
        _ => with_potential!(pot, |p| trigint_core::integrate_batch::<BatchLanes, _>(
            p, lay, &methods, &q0, &p0, &n_steps, form, record, &stop, 4096,
        )),
    })?;
    let interrupted_by = interrupted.then(|| "KeyboardInterrupt".to_string());
    result::from_outputs(
        py,
        out,
        n,
        channel_count(lay.n_blocks(), lay.n_axes()),
        save_every.is_some(),
        interrupted,
        interrupted_by,
    )
}

/// state_energies(potential, layout, q, p, modified=None) -> array (B, channels)
///
/// The energy channels of each row of q, p (B × n, the core's coordinates) in the order of
/// `channels(ℓ, axes)`, as a run observes its initial state; `modified` = (a, b), the modified
/// energy's weights (3.4), or None for H* = H_ω.
#[pyfunction]
#[pyo3(signature = (potential, layout, q, p, modified=None))]
fn state_energies<'py>(
    py: Python<'py>,
    potential: &Bound<'py, PyAny>,
    layout: &Bound<'py, PyAny>,
    q: PyReadonlyArray2<f64>,
    p: PyReadonlyArray2<f64>,
    modified: Option<(PyReadonlyArray1<f64>, PyReadonlyArray1<f64>)>,
) -> PyResult<Bound<'py, numpy::PyArray2<f64>>> {
    let given = handle::given(potential)?;
    let pot = given.get();
    let given_layout = handle::given_layout(layout)?;
    let lay = given_layout.get();
    let rows = q.shape()[0];
    let (q, p): (Vec<f64>, Vec<f64>) = (
        q.as_array().iter().copied().collect(),
        p.as_array().iter().copied().collect(),
    );
    let modified = modified.map(|(a, b)| (convert::vec1(a), convert::vec1(b)));
    let weights = modified.as_ref().map(|(a, b)| (&a[..], &b[..]));
    let out = with_potential!(pot, |pt| trigint_core::run::state_energies(
        pt, lay, weights, &q, &p
    ))
    .map_err(|e| to_py(e, pot))?;
    to_2d(py, out, rows, channel_count(lay.n_blocks(), lay.n_axes()))
}

/// U at each row and −∇U at each row.
pub(crate) type ValuesAndForces<'py> =
    (Bound<'py, PyArray1<f64>>, Bound<'py, numpy::PyArray2<f64>>);

/// channels(n_blocks, n_axes=0) -> the energy channel names in output order (n_axes: the
/// per-axis channels of a pair form, such as a wave equation's momentum)
#[pyfunction]
#[pyo3(signature = (n_blocks, n_axes = 0))]
fn channels(n_blocks: usize, n_axes: usize) -> Vec<String> {
    channel_names(n_blocks, n_axes)
}

/// kernel_config() -> dict: the CPU, the kernel copies it may run, how copies are chosen, the
/// plan cache and the plans known to this process (what `trigint info` prints)
#[pyfunction]
fn kernel_config(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    use trigint_core::{cpu, isa, plan};
    let d = PyDict::new(py);
    d.set_item("cpu", cpu::model())?;
    d.set_item("features", cpu::features())?;
    let allowed = isa::allowed();
    let mut copies = Vec::new();
    if allowed.avx512 {
        copies.push("avx512");
    }
    if allowed.avx2 {
        copies.push("avx2");
    }
    copies.push("baseline");
    d.set_item("copies", copies)?;
    d.set_item("isa_cap", std::env::var("TRIGINT_ISA").ok())?;
    d.set_item("plan_mode", plan::mode().name())?;
    d.set_item(
        "plan_cache",
        plan::cache_path().map(|p| p.display().to_string()),
    )?;
    let rows = PyList::empty(py);
    for r in plan::report() {
        let row = PyDict::new(py);
        row.set_item("loop", r.key)?;
        row.set_item("chosen", r.chosen)?;
        row.set_item("timings", r.timings)?;
        rows.append(row)?;
    }
    d.set_item("plans", rows)?;
    d.set_item("core_version", env!("CARGO_PKG_VERSION"))?;
    d.set_item("core_build", plan::build_id())?;
    Ok(d)
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    // The library's constants in the page tables before any kernel runs (see `resident`).
    trigint_core::resident::map_read_only_data();
    m.add_function(wrap_pyfunction!(integrate, m)?)?;
    m.add_function(wrap_pyfunction!(integrate_batch, m)?)?;
    m.add_function(wrap_pyfunction!(tangent::tangent, m)?)?;
    m.add_function(wrap_pyfunction!(tangent::tangent_batch, m)?)?;
    m.add_function(wrap_pyfunction!(state_energies, m)?)?;
    m.add_class::<handle::Handle>()?;
    m.add_class::<handle::LayoutHandle>()?;
    m.add_class::<handle::MethodHandle>()?;
    m.add_class::<RunResult>()?;
    m.add_class::<grid::FourierGrid>()?;
    m.add_class::<coordinates::CoordinateMap>()?;
    m.add_function(wrap_pyfunction!(channels, m)?)?;
    m.add_function(wrap_pyfunction!(kernel_config, m)?)?;
    m.add_function(wrap_pyfunction!(krylov::integrate_krylov, m)?)?;
    m.add_function(wrap_pyfunction!(krylov::tangent_krylov, m)?)?;
    m.add_function(wrap_pyfunction!(krylov::krylov_energies, m)?)?;
    m.add(
        "KRYLOV_FUNCTIONS",
        PyTuple::new(m.py(), trigint_core::krylov::FUNCTIONS)?,
    )?;
    m.add(
        "KRYLOV_FILTERS",
        PyTuple::new(m.py(), trigint_core::krylov::Filter::LETTERS)?,
    )?;
    // The schemas, written once in the core: the method rows and the energy channels.
    m.add(
        "METHOD_ROWS",
        PyTuple::new(m.py(), MethodCoefficients::ROWS)?,
    )?;
    let channels = PyList::empty(m.py());
    for c in CHANNELS {
        let d = PyDict::new(m.py());
        d.set_item("name", c.name)?;
        d.set_item("form", c.form)?;
        d.set_item("per_block", c.per_block)?;
        d.set_item("per_axis", c.per_axis)?;
        channels.append(d)?;
    }
    m.add("CHANNELS", channels)?;
    Ok(())
}

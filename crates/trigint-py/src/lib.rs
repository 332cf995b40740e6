//! The PyO3 binding of trigint-core: converts arrays, releases the GIL around the core,
//! and maps core errors to Python exceptions. No numerics live here.

mod potential;

use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use trigint_core::{CoreError, EnergyLayout, Form, MethodCoefficients, RunOutput, RunSpec};

use potential::NativePotential;

/// Core errors become Python exceptions here and nowhere else.
pub(crate) struct TrigintError(CoreError);

impl From<CoreError> for TrigintError {
    fn from(e: CoreError) -> Self {
        TrigintError(e)
    }
}

impl From<TrigintError> for PyErr {
    fn from(e: TrigintError) -> PyErr {
        match e.0 {
            CoreError::InvalidArgument { .. } | CoreError::DimensionMismatch { .. } => {
                PyValueError::new_err(e.0.to_string())
            }
            CoreError::Potential(_) => PyRuntimeError::new_err(e.0.to_string()),
        }
    }
}

fn vec1(a: &PyReadonlyArray1<f64>) -> Vec<f64> {
    a.as_array().to_vec()
}

/// A row-major buffer as an (n_rows, n_cols) NumPy array, without copying.
fn to_2d(
    py: Python<'_>,
    data: Vec<f64>,
    n_rows: usize,
    n_cols: usize,
) -> PyResult<Bound<'_, PyArray2<f64>>> {
    PyArray1::from_vec(py, data).reshape([n_rows, n_cols])
}

/// (h, 1 − cos, sin, χ, ψ, φ) per coordinate.
type CoefficientArrays<'py> = (
    f64,
    PyReadonlyArray1<'py, f64>,
    PyReadonlyArray1<'py, f64>,
    PyReadonlyArray1<'py, f64>,
    PyReadonlyArray1<'py, f64>,
    PyReadonlyArray1<'py, f64>,
);

/// (ω², modified-energy weights of p² and q², block of each coordinate, ℓ).
type LayoutArrays<'py> = (
    PyReadonlyArray1<'py, f64>,
    PyReadonlyArray1<'py, f64>,
    PyReadonlyArray1<'py, f64>,
    Vec<usize>,
    usize,
);

/// integrate(potential, coefficients, layout, q0, p0, n_steps, save_every, form, track,
/// progress_every, progress) -> dict
///
/// `coefficients` is (h, 1 − cos, sin, chi, psi, phi); `layout` is (omega2, modified_p,
/// modified_q, block, n_blocks). `progress(steps_done)` is called between chunks and may
/// return False to stop; Ctrl-C also stops the run, which then reports "interrupted".
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (potential, coefficients, layout, q0, p0, n_steps, save_every, form, track, progress_every, progress=None))]
fn integrate<'py>(
    py: Python<'py>,
    potential: &Bound<'py, PyAny>,
    coefficients: CoefficientArrays<'py>,
    layout: LayoutArrays<'py>,
    q0: PyReadonlyArray1<f64>,
    p0: PyReadonlyArray1<f64>,
    n_steps: u64,
    save_every: u64,
    form: &str,
    track: bool,
    progress_every: u64,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let pot = NativePotential::from_spec(potential)?;
    let (h, one_minus_cos, sin, chi, psi, phi) = coefficients;
    let co = MethodCoefficients {
        h,
        one_minus_cos: vec1(&one_minus_cos),
        sin: vec1(&sin),
        chi: vec1(&chi),
        psi: vec1(&psi),
        phi: vec1(&phi),
    };
    let (omega2, modified_p, modified_q, block, n_blocks) = layout;
    let lay = EnergyLayout {
        omega2: vec1(&omega2),
        modified_p: vec1(&modified_p),
        modified_q: vec1(&modified_q),
        block,
        n_blocks,
    };
    let form = match form {
        "two-step" => Form::TwoStep,
        "one-step" => Form::OneStep,
        other => {
            return Err(PyValueError::new_err(format!(
                "form must be 'two-step' or 'one-step', got {other:?}"
            )))
        }
    };
    let spec = RunSpec {
        n_steps,
        save_every,
        form,
        track_energies: track,
        progress_every,
    };
    let (q0, p0) = (vec1(&q0), vec1(&p0));

    // The callback re-attaches to the interpreter between chunks: it checks for Ctrl-C and
    // calls the user's progress function. A raised exception stops the run and is re-raised.
    let mut pending: Option<PyErr> = None;
    let mut report = |done: u64| -> bool {
        Python::attach(|py| {
            if let Err(e) = py.check_signals() {
                pending = Some(e);
                return false;
            }
            match &progress {
                None => true,
                Some(cb) => match cb.call1(py, (done,)) {
                    // Only an explicit False stops the run; None (no return) continues.
                    Ok(r) => r.extract::<bool>(py).unwrap_or(true),
                    Err(e) => {
                        pending = Some(e);
                        false
                    }
                },
            }
        })
    };
    let out: Result<RunOutput, CoreError> =
        py.detach(|| pot.integrate(&co, &lay, &q0, &p0, &spec, &mut report));
    let out = match out {
        Ok(o) => o,
        Err(e) => return Err(pot.take_error().unwrap_or_else(|| TrigintError(e).into())),
    };
    let interrupted_by = pending.map(|e| e.to_string());
    let n = q0.len();
    let c = lay.n_channels();
    let n_samples = out.samples.steps.len();
    let d = PyDict::new(py);
    d.set_item("status", out.status.as_str())?;
    d.set_item("steps_done", out.steps_done)?;
    d.set_item("message", out.message)?;
    d.set_item("interrupted_by", interrupted_by)?;
    d.set_item("steps", PyArray1::from_vec(py, out.samples.steps))?;
    d.set_item("q", to_2d(py, out.samples.q, n_samples, n)?)?;
    d.set_item("p", to_2d(py, out.samples.p, n_samples, n)?)?;
    d.set_item("energies", to_2d(py, out.samples.energies, n_samples, c)?)?;
    d.set_item(
        "initial_energies",
        PyArray1::from_vec(py, out.initial_energies),
    )?;
    d.set_item("max_deviation", PyArray1::from_vec(py, out.max_deviation))?;
    Ok(d)
}

/// potential_value(potential, x) -> U at each row of x (shape (m, n)).
#[pyfunction]
fn potential_value<'py>(
    py: Python<'py>,
    potential: &Bound<'py, PyAny>,
    x: PyReadonlyArray2<f64>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let pot = NativePotential::from_spec(potential)?;
    let x = x.as_array();
    let (m, n) = (x.nrows(), x.ncols());
    let data: Vec<f64> = x.iter().copied().collect();
    let r = py.detach(|| pot.values(&data, m, n));
    match r {
        Ok(v) => Ok(PyArray1::from_vec(py, v)),
        Err(e) => Err(pot.take_error().unwrap_or_else(|| TrigintError(e).into())),
    }
}

/// potential_force(potential, x) -> g = −∇U at each row of x (shape (m, n)).
#[pyfunction]
fn potential_force<'py>(
    py: Python<'py>,
    potential: &Bound<'py, PyAny>,
    x: PyReadonlyArray2<f64>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let pot = NativePotential::from_spec(potential)?;
    let x = x.as_array();
    let (m, n) = (x.nrows(), x.ncols());
    let data: Vec<f64> = x.iter().copied().collect();
    let r = py.detach(|| pot.forces(&data, m, n));
    match r {
        Ok(v) => to_2d(py, v, m, n),
        Err(e) => Err(pot.take_error().unwrap_or_else(|| TrigintError(e).into())),
    }
}

/// One batch call's inputs, per trajectory in rows: (h, 1 − cos, sin, χ, ψ, φ, H* weights of
/// p² and q²), the rows being (B, n) arrays and h a (B,) array.
type BatchCoefficients<'py> = (
    PyReadonlyArray1<'py, f64>,
    PyReadonlyArray2<'py, f64>,
    PyReadonlyArray2<'py, f64>,
    PyReadonlyArray2<'py, f64>,
    PyReadonlyArray2<'py, f64>,
    PyReadonlyArray2<'py, f64>,
    PyReadonlyArray2<'py, f64>,
    PyReadonlyArray2<'py, f64>,
);

/// integrate_batch(potential, coefficients, layout, q0, p0, n_steps, save_every, track, block,
/// threads) -> dict
///
/// Runs the batched kernel on a thread pool of `threads` (None: all cores) while this thread
/// watches for Ctrl-C; on Ctrl-C the unfinished trajectories end "interrupted" and the result
/// says so in `interrupted`.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (potential, coefficients, layout, q0, p0, n_steps, save_every, track, block, threads=None))]
fn integrate_batch<'py>(
    py: Python<'py>,
    potential: &Bound<'py, PyAny>,
    coefficients: BatchCoefficients<'py>,
    layout: LayoutArrays<'py>,
    q0: PyReadonlyArray2<f64>,
    p0: PyReadonlyArray2<f64>,
    n_steps: Vec<u64>,
    save_every: Option<u64>,
    track: bool,
    block: usize,
    threads: Option<usize>,
) -> PyResult<Bound<'py, PyDict>> {
    use std::sync::atomic::{AtomicBool, Ordering};
    use trigint_core::{BatchSpec, TrajectoryMethod};

    let pot = NativePotential::from_spec(potential)?;
    let (h, omc, sin, chi, psi, phi, mp, mq) = coefficients;
    let rows = |a: &PyReadonlyArray2<f64>| -> Vec<Vec<f64>> {
        a.as_array()
            .rows()
            .into_iter()
            .map(|r| r.to_vec())
            .collect()
    };
    let h = h.as_array().to_vec();
    let (omc, sin, chi, psi, phi, mp, mq) = (
        rows(&omc),
        rows(&sin),
        rows(&chi),
        rows(&psi),
        rows(&phi),
        rows(&mp),
        rows(&mq),
    );
    let count = h.len();
    for (name, r) in [
        ("one_minus_cos", &omc),
        ("sin", &sin),
        ("chi", &chi),
        ("psi", &psi),
        ("phi", &phi),
        ("modified_p", &mp),
        ("modified_q", &mq),
    ] {
        if r.len() != count {
            return Err(PyValueError::new_err(format!(
                "{name}: {} rows for {count} trajectories",
                r.len()
            )));
        }
    }
    let methods: Vec<TrajectoryMethod> = (0..count)
        .map(|t| TrajectoryMethod {
            coefficients: MethodCoefficients {
                h: h[t],
                one_minus_cos: omc[t].clone(),
                sin: sin[t].clone(),
                chi: chi[t].clone(),
                psi: psi[t].clone(),
                phi: phi[t].clone(),
            },
            modified_p: mp[t].clone(),
            modified_q: mq[t].clone(),
        })
        .collect();
    let (omega2, modified_p, modified_q, blocks, n_blocks) = layout;
    let lay = EnergyLayout {
        omega2: vec1(&omega2),
        modified_p: vec1(&modified_p),
        modified_q: vec1(&modified_q),
        block: blocks,
        n_blocks,
    };
    let n = lay.dim();
    let (q0, p0): (Vec<f64>, Vec<f64>) = (
        q0.as_array().iter().copied().collect(),
        p0.as_array().iter().copied().collect(),
    );
    let spec = BatchSpec {
        save_every,
        track_energies: track,
        block,
    };
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(t) = threads {
        builder = builder.num_threads(t);
    }
    let pool = builder
        .build()
        .map_err(|e| PyRuntimeError::new_err(format!("could not start threads: {e}")))?;
    let stop = AtomicBool::new(false);
    let mut interrupted = false;
    let out = py.detach(|| {
        std::thread::scope(|scope| {
            let worker = scope.spawn(|| {
                pool.install(|| {
                    pot.integrate_batch(&methods, &lay, &q0, &p0, &n_steps, &spec, &stop)
                })
            });
            while !worker.is_finished() {
                std::thread::sleep(std::time::Duration::from_millis(20));
                if !interrupted && Python::attach(|py| py.check_signals().is_err()) {
                    interrupted = true;
                    stop.store(true, Ordering::Relaxed);
                }
            }
            worker.join()
        })
    });
    let out = match out {
        Ok(Ok(o)) => o,
        Ok(Err(e)) => return Err(pot.take_error().unwrap_or_else(|| TrigintError(e).into())),
        Err(_) => return Err(PyRuntimeError::new_err("the batch worker panicked")),
    };
    let c = lay.n_channels();
    let d = PyDict::new(py);
    let statuses: Vec<&str> = out.iter().map(|o| o.status.as_str()).collect();
    d.set_item("status", statuses)?;
    d.set_item(
        "steps_done",
        PyArray1::from_vec(py, out.iter().map(|o| o.steps_done).collect()),
    )?;
    d.set_item(
        "initial_energies",
        to_2d(
            py,
            out.iter()
                .flat_map(|o| o.initial_energies.clone())
                .collect(),
            count,
            c,
        )?,
    )?;
    d.set_item(
        "max_deviation",
        to_2d(
            py,
            out.iter().flat_map(|o| o.max_deviation.clone()).collect(),
            count,
            c,
        )?,
    )?;
    d.set_item("interrupted", interrupted)?;
    if save_every.is_some() {
        let samples = pyo3::types::PyList::empty(py);
        for o in out {
            let s = o.samples;
            let k = s.steps.len();
            let item = PyDict::new(py);
            item.set_item("steps", PyArray1::from_vec(py, s.steps))?;
            item.set_item("q", to_2d(py, s.q, k, n)?)?;
            item.set_item("p", to_2d(py, s.p, k, n)?)?;
            item.set_item("energies", to_2d(py, s.energies, k, c)?)?;
            samples.append(item)?;
        }
        d.set_item("samples", samples)?;
    }
    Ok(d)
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(integrate, m)?)?;
    m.add_function(wrap_pyfunction!(integrate_batch, m)?)?;
    m.add_function(wrap_pyfunction!(potential_value, m)?)?;
    m.add_function(wrap_pyfunction!(potential_force, m)?)?;
    Ok(())
}

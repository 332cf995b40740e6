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

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(integrate, m)?)?;
    m.add_function(wrap_pyfunction!(potential_value, m)?)?;
    m.add_function(wrap_pyfunction!(potential_force, m)?)?;
    Ok(())
}

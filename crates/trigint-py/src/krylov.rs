//! The Krylov path's entry point, `_core.integrate_krylov`: a sparse stiffness matrix in CSR,
//! the Lanczos method in the core, one trajectory or an ensemble on a thread pool.

use std::sync::atomic::AtomicBool;
use std::sync::Mutex;

use numpy::{PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use trigint_core::channels::OSCILLATORY;
use trigint_core::krylov::{
    self, Csr, Filter, KrylovCounts, MatrixFunctions, Settings, Trigonometric, Values,
    FUNCTION_COUNT,
};
use trigint_core::{channel_count, Control, CoreError, CoreResult, Record, TrajectoryOutput};

use crate::convert::item;
use crate::handle;
use crate::potential::{with_potential, NativePotential};
use crate::result::{self, RunResult};
use crate::{to_py, watch};

/// One trajectory's matrix functions: the closed forms of a named trigonometric method (no
/// Python in the step), or a Python callable θ ↦ array (7, len θ) in `KRYLOV_FUNCTIONS` order
/// for every other method (called once per Lanczos step with the Ritz values).
enum Functions {
    Closed(Trigonometric),
    Python {
        callable: Py<PyAny>,
        phi: bool,
        error: Mutex<Option<PyErr>>,
    },
}

impl Functions {
    /// From `{"h", "filter": "A"…"E"}` or `{"h", "functions": callable, "phi_is_identity"}`.
    fn from_spec(d: &Bound<'_, PyDict>) -> PyResult<Self> {
        let h: f64 = item(d, "h")?;
        if let Some(f) = d.get_item("filter")? {
            let letter: String = f.extract()?;
            let filter = Filter::from_letter(&letter).ok_or_else(|| {
                PyValueError::new_err(format!("filter: expected a letter A-E, got {letter:?}"))
            })?;
            return Ok(Functions::Closed(Trigonometric { h, filter }));
        }
        Ok(Functions::Python {
            callable: item(d, "functions")?,
            phi: item(d, "phi_is_identity")?,
            error: Mutex::new(None),
        })
    }

    fn take_error(&self) -> Option<PyErr> {
        match self {
            Functions::Python { error, .. } => error.lock().ok()?.take(),
            Functions::Closed(_) => None,
        }
    }
}

impl MatrixFunctions for Functions {
    fn evaluate(&self, theta: &[f64], values: &mut Values) -> CoreResult<()> {
        let (callable, error) = match self {
            Functions::Closed(t) => return t.evaluate(theta, values),
            Functions::Python {
                callable, error, ..
            } => (callable, error),
        };
        Python::attach(|py| {
            let r = (|| -> PyResult<()> {
                let x = PyArray1::from_iter(py, theta.iter().map(|t| t.max(0.0)));
                let out = callable.call1(py, (x,))?;
                let a: PyReadonlyArray2<f64> = out.extract(py)?;
                if a.shape() != [FUNCTION_COUNT, theta.len()] {
                    return Err(PyValueError::new_err(format!(
                        "the method's matrix functions returned shape {:?}, expected ({FUNCTION_COUNT}, {})",
                        a.shape(),
                        theta.len()
                    )));
                }
                let a = a.as_array();
                for (f, row) in values.iter_mut().enumerate() {
                    row.clear();
                    row.extend(a.row(f).iter().copied());
                }
                Ok(())
            })();
            r.map_err(|e| {
                let text = e.to_string();
                if let Ok(mut slot) = error.lock() {
                    *slot = Some(e);
                }
                CoreError::invalid("method", format!("the matrix functions failed: {text}"))
            })
        })
    }

    fn phi_is_identity(&self) -> bool {
        match self {
            Functions::Closed(t) => t.phi_is_identity(),
            Functions::Python { phi, .. } => *phi,
        }
    }
}

fn indices(a: PyReadonlyArray1<i64>, what: &str) -> PyResult<Vec<usize>> {
    a.as_array()
        .iter()
        .map(|&i| {
            usize::try_from(i)
                .map_err(|_| PyValueError::new_err(format!("stiffness: negative {what} {i}")))
        })
        .collect()
}

/// The stiffness matrix from its CSR arrays.
fn csr(
    n: usize,
    indptr: PyReadonlyArray1<i64>,
    indices_: PyReadonlyArray1<i64>,
    data: PyReadonlyArray1<f64>,
    pot: &NativePotential,
) -> PyResult<Csr> {
    Csr::new(
        n,
        indices(indptr, "row pointer")?,
        indices(indices_, "column index")?,
        data.as_array().to_vec(),
    )
    .map_err(|e| to_py(e, pot))
}

/// integrate_krylov(potential, n, indptr, indices, data, methods, tol, max_iterations, q0, p0, n_steps,
/// save_every, track, threads=None, progress_every=64, progress=None) -> RunResult
///
/// Every row of q0, p0 (B × n) is one trajectory with its method (a dict per trajectory, see
/// `Functions`) and step count. One trajectory runs on this thread and calls `progress(step)`
/// every `progress_every` steps (False stops it); more run on a pool of `threads` while this
/// thread watches for Ctrl-C. `info` holds per-trajectory Lanczos counts.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (potential, n, indptr, indices_, data, methods, tol, max_iterations, q0, p0, n_steps, save_every, track, threads=None, progress_every=64, progress=None))]
pub fn integrate_krylov<'py>(
    py: Python<'py>,
    potential: &Bound<'py, PyAny>,
    n: usize,
    indptr: PyReadonlyArray1<i64>,
    indices_: PyReadonlyArray1<i64>,
    data: PyReadonlyArray1<f64>,
    methods: Vec<Bound<'py, PyDict>>,
    tol: f64,
    max_iterations: usize,
    q0: PyReadonlyArray2<f64>,
    p0: PyReadonlyArray2<f64>,
    n_steps: Vec<u64>,
    save_every: Option<u64>,
    track: bool,
    threads: Option<usize>,
    progress_every: u64,
    progress: Option<Py<PyAny>>,
) -> PyResult<RunResult> {
    let given = handle::given(potential)?;
    let pot = given.get();
    let a = csr(n, indptr, indices_, data, pot)?;
    let functions = methods
        .iter()
        .map(Functions::from_spec)
        .collect::<PyResult<Vec<_>>>()?;
    let hs: Vec<f64> = methods
        .iter()
        .map(|d| item::<f64>(d, "h"))
        .collect::<PyResult<_>>()?;
    let (q0, p0): (Vec<f64>, Vec<f64>) = (
        q0.as_array().iter().copied().collect(),
        p0.as_array().iter().copied().collect(),
    );
    let lanczos = Settings {
        tol,
        max_iterations,
    };
    let record = Record { save_every, track };
    let mut pending: Option<PyErr> = None;
    let mut interrupted = false;
    let out: CoreResult<Vec<(TrajectoryOutput, KrylovCounts)>> = if hs.len() == 1 {
        let mut report = watch::reporter(&progress, &mut pending);
        py.detach(|| {
            let mut control = Control {
                every: progress_every.max(1),
                report: &mut report,
            };
            let r = with_potential!(pot, |p| krylov::integrate(
                &a,
                p,
                &functions[0],
                hs[0],
                lanczos,
                &q0,
                &p0,
                n_steps[0],
                record,
                &mut control
            ));
            r.map(|o| vec![o])
        })
    } else {
        let stop = AtomicBool::new(false);
        let refs: Vec<&dyn MatrixFunctions> = functions
            .iter()
            .map(|f| f as &dyn MatrixFunctions)
            .collect();
        let run = || {
            let mut builder = rayon::ThreadPoolBuilder::new();
            if let Some(t) = threads {
                builder = builder.num_threads(t);
            }
            builder.build().map(|pool| {
                pool.install(|| {
                    with_potential!(pot, |p| krylov::integrate_batch(
                        &a, p, &refs, &hs, lanczos, &q0, &p0, &n_steps, record, &stop, 1
                    ))
                })
            })
        };
        let joined;
        (joined, interrupted) = watch::watching_ctrl_c(py, &stop, run);
        match joined {
            Ok(Ok(r)) => r,
            Ok(Err(e)) => {
                return Err(PyRuntimeError::new_err(format!(
                    "could not start threads: {e}"
                )))
            }
            Err(_) => return Err(PyRuntimeError::new_err("the Krylov worker panicked")),
        }
    };
    if let Some(e) = functions.iter().find_map(Functions::take_error) {
        return Err(e);
    }
    let out = out.map_err(|e| to_py(e, pot))?;
    let iterations: Vec<u64> = out.iter().map(|(_, c)| c.iterations).collect();
    let products: Vec<u64> = out.iter().map(|(_, c)| c.products).collect();
    let outputs: Vec<TrajectoryOutput> = out.into_iter().map(|(o, _)| o).collect();
    // One trajectory: stopped by its callback or Ctrl-C (`pending` says which); a batch: Ctrl-C.
    let (interrupted, by) = if outputs.len() == 1 {
        let stopped = outputs[0].status == trigint_core::Status::Interrupted;
        (stopped, pending.map(|e| e.to_string()))
    } else {
        (
            interrupted,
            interrupted.then(|| "KeyboardInterrupt".to_string()),
        )
    };
    let keep = save_every.is_some();
    let r = result::from_outputs(py, outputs, n, channel_count(1, 0), keep, interrupted, by)?;
    let info = PyDict::new(py);
    info.set_item("iterations", iterations)?;
    info.set_item("products", products)?;
    info.set_item("tolerance", tol)?;
    Ok(r.with_info(info))
}

/// krylov_energies(potential, n, indptr, indices, data, q, p) -> array (B, channels)
///
/// The channels of each row of q, p (B × n) on the Krylov path, in the order of
/// `channels(1)`, by the core's formula (the one its runs stream; NaN for the modified energy).
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (potential, n, indptr, indices_, data, q, p))]
pub fn krylov_energies<'py>(
    py: Python<'py>,
    potential: &Bound<'py, PyAny>,
    n: usize,
    indptr: PyReadonlyArray1<i64>,
    indices_: PyReadonlyArray1<i64>,
    data: PyReadonlyArray1<f64>,
    q: PyReadonlyArray2<f64>,
    p: PyReadonlyArray2<f64>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let given = handle::given(potential)?;
    let pot = given.get();
    let a = csr(n, indptr, indices_, data, pot)?;
    let (q, p): (Vec<f64>, Vec<f64>) = (
        q.as_array().iter().copied().collect(),
        p.as_array().iter().copied().collect(),
    );
    let rows = with_potential!(pot, |pt| krylov::state_energies(&a, pt, &q, &p))
        .map_err(|e| to_py(e, pot))?;
    // The row as a run records it: the main channels, then I_1 = H_ω of the one block.
    let picked: Vec<Vec<f64>> = rows
        .iter()
        .map(|e| e.iter().copied().chain([e[OSCILLATORY]]).collect())
        .collect();
    PyArray2::from_vec2(py, &picked).map_err(|e| PyValueError::new_err(e.to_string()))
}

/// tangent_krylov(potential, n, indptr, indices, data, method, tol, max_iterations, q0, p0, dq0,
/// dp0, metric, n_steps, renormalize_every, sample_every, progress_every, progress=None) -> dict
///
/// `_core.tangent` on the Krylov path (one trajectory, its method a dict as `integrate_krylov`
/// takes): the same dict back.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (potential, n, indptr, indices_, data, method, tol, max_iterations, q0, p0, dq0, dp0, metric, n_steps, renormalize_every, sample_every, progress_every, progress=None))]
pub fn tangent_krylov<'py>(
    py: Python<'py>,
    potential: &Bound<'py, PyAny>,
    n: usize,
    indptr: PyReadonlyArray1<i64>,
    indices_: PyReadonlyArray1<i64>,
    data: PyReadonlyArray1<f64>,
    method: Bound<'py, PyDict>,
    tol: f64,
    max_iterations: usize,
    q0: PyReadonlyArray1<f64>,
    p0: PyReadonlyArray1<f64>,
    dq0: PyReadonlyArray2<f64>,
    dp0: PyReadonlyArray2<f64>,
    metric: PyReadonlyArray1<f64>,
    n_steps: u64,
    renormalize_every: u64,
    sample_every: u64,
    progress_every: u64,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let given = handle::given(potential)?;
    let pot = given.get();
    let a = csr(n, indptr, indices_, data, pot)?;
    let functions = Functions::from_spec(&method)?;
    let h: f64 = item(&method, "h")?;
    let flat = |a: PyReadonlyArray1<f64>| a.as_array().to_vec();
    let (q0, p0, metric) = (flat(q0), flat(p0), flat(metric));
    let k = dq0.as_array().nrows();
    let rows = |a: PyReadonlyArray2<f64>| a.as_array().iter().copied().collect::<Vec<f64>>();
    let (dq0, dp0) = (rows(dq0), rows(dp0));
    let request = trigint_core::TangentRequest {
        n_steps,
        renormalize_every,
        sample_every,
    };
    let lanczos = Settings {
        tol,
        max_iterations,
    };
    let mut pending: Option<PyErr> = None;
    let out = {
        let mut report = watch::reporter(&progress, &mut pending);
        py.detach(|| {
            let mut control = Control {
                every: progress_every.max(1),
                report: &mut report,
            };
            with_potential!(pot, |p| krylov::tangent(
                &a,
                p,
                &functions,
                h,
                lanczos,
                &q0,
                &p0,
                &dq0,
                &dp0,
                &metric,
                &request,
                &mut control
            ))
        })
    };
    if let Some(e) = functions.take_error() {
        return Err(e);
    }
    let out = out.map_err(|e| to_py(e, pot))?;
    crate::tangent::output_dict(py, out, k, n, pending)
}

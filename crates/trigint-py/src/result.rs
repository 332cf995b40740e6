//! The one result type of every entry point: [`RunResult`], for one trajectory or many, built by
//! `integrate`, `integrate_batch` and (from Python) the Krylov path.

use numpy::{PyArray1, PyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};
use trigint_core::{Samples, TrajectoryOutput};

use crate::potential::to_2d;

/// The outcome of a run of one or many trajectories, in the trajectories' order.
///
/// `status` and `messages` per trajectory ("completed", "blow-up" or "interrupted", and what
/// happened in words); `steps_done` (steps taken); `initial_energies` and `max_deviation`
/// (trajectories × channels, the channels of `_core.CHANNELS`; NaN where not tracked);
/// `samples` (per trajectory a dict of `steps`, `q`, `p`, `energies`, or None when the run
/// keeps no states); `interrupted` (a stop request ended the run) and `interrupted_by` (the
/// exception that stopped it, as text); `info` (what an entry point adds, e.g. the Krylov
/// path's iteration counts).
#[pyclass(module = "trigint._core", frozen, get_all)]
pub struct RunResult {
    status: Vec<String>,
    messages: Vec<String>,
    steps_done: Py<PyArray1<u64>>,
    initial_energies: Py<PyArray2<f64>>,
    max_deviation: Py<PyArray2<f64>>,
    samples: Option<Py<PyList>>,
    interrupted: bool,
    interrupted_by: Option<String>,
    info: Py<PyDict>,
}

#[pymethods]
impl RunResult {
    #[new]
    #[allow(clippy::too_many_arguments)]
    #[pyo3(signature = (status, messages, steps_done, initial_energies, max_deviation, samples=None, interrupted=false, interrupted_by=None, info=None))]
    fn new(
        py: Python<'_>,
        status: Vec<String>,
        messages: Vec<String>,
        steps_done: Bound<'_, PyArray1<u64>>,
        initial_energies: Bound<'_, PyArray2<f64>>,
        max_deviation: Bound<'_, PyArray2<f64>>,
        samples: Option<Bound<'_, PyList>>,
        interrupted: bool,
        interrupted_by: Option<String>,
        info: Option<Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let count = status.len();
        let rows = |a: &[usize]| a.first().copied().unwrap_or(0);
        let consistent = messages.len() == count
            && steps_done.len() == count
            && rows(initial_energies.shape()) == count
            && initial_energies.shape() == max_deviation.shape()
            && samples.as_ref().is_none_or(|s| s.len() == count);
        if !consistent {
            return Err(PyValueError::new_err(format!(
                "RunResult: {count} statuses, {} messages, {} step counts, energies of shape {:?} \
                 and {:?}, {} sample sets: one of each per trajectory expected",
                messages.len(),
                steps_done.len(),
                initial_energies.shape(),
                max_deviation.shape(),
                samples.as_ref().map_or(count, |s| s.len())
            )));
        }
        Ok(RunResult {
            status,
            messages,
            steps_done: steps_done.unbind(),
            initial_energies: initial_energies.unbind(),
            max_deviation: max_deviation.unbind(),
            samples: samples.map(Bound::unbind),
            interrupted,
            interrupted_by,
            info: info.unwrap_or_else(|| PyDict::new(py)).unbind(),
        })
    }

    fn __len__(&self) -> usize {
        self.status.len()
    }

    /// Pickled as its constructor's arguments (results travel back from process pools and
    /// Dask workers).
    fn __reduce__<'py>(
        slf: &Bound<'py, Self>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyTuple>)> {
        let py = slf.py();
        let r = slf.get();
        let args = (
            r.status.clone(),
            r.messages.clone(),
            r.steps_done.clone_ref(py),
            r.initial_energies.clone_ref(py),
            r.max_deviation.clone_ref(py),
            r.samples.as_ref().map(|s| s.clone_ref(py)),
            r.interrupted,
            r.interrupted_by.clone(),
            r.info.clone_ref(py),
        );
        Ok((slf.get_type().into_any(), args.into_pyobject(py)?))
    }

    fn __repr__(&self) -> String {
        let mut counts: Vec<(String, usize)> = Vec::new();
        for s in &self.status {
            match counts.iter_mut().find(|(k, _)| k == s) {
                Some((_, n)) => *n += 1,
                None => counts.push((s.clone(), 1)),
            }
        }
        let counts: Vec<String> = counts.iter().map(|(k, n)| format!("{n} {k}")).collect();
        format!("RunResult({})", counts.join(", "))
    }
}

impl RunResult {
    /// The result with `info` replaced (what an entry point adds).
    pub fn with_info(self, info: Bound<'_, PyDict>) -> Self {
        RunResult {
            info: info.unbind(),
            ..self
        }
    }
}

fn samples_dict<'py>(
    py: Python<'py>,
    s: Samples,
    n: usize,
    c: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let k = s.steps.len();
    let d = PyDict::new(py);
    d.set_item("steps", PyArray1::from_vec(py, s.steps))?;
    d.set_item("q_in_user", PyArray1::from_vec(py, s.q_in_user))?;
    d.set_item("q", to_2d(py, s.q, k, n)?)?;
    d.set_item("p", to_2d(py, s.p, k, n)?)?;
    d.set_item("energies", to_2d(py, s.energies, k, c)?)?;
    Ok(d)
}

/// The result of the core's outputs for `n` coordinates and `c` channels.
pub fn from_outputs(
    py: Python<'_>,
    out: Vec<TrajectoryOutput>,
    n: usize,
    c: usize,
    keep_samples: bool,
    interrupted: bool,
    interrupted_by: Option<String>,
) -> PyResult<RunResult> {
    let mut out = out;
    let count = out.len();
    // (one trajectory's rows are moved, not copied: a wave has a channel per mode)
    let mut flat = |f: fn(&mut TrajectoryOutput) -> &mut Vec<f64>| -> Vec<f64> {
        match &mut out[..] {
            [one] => std::mem::take(f(one)),
            all => {
                let mut rows = Vec::with_capacity(all.len() * c);
                for o in all.iter_mut() {
                    rows.extend_from_slice(f(o));
                }
                rows
            }
        }
    };
    let initial = to_2d(py, flat(|o| &mut o.initial_energies), count, c)?;
    let deviation = to_2d(py, flat(|o| &mut o.max_deviation), count, c)?;
    let status = out.iter().map(|o| o.status.as_str().to_string()).collect();
    let steps = PyArray1::from_vec(py, out.iter().map(|o| o.steps_done).collect());
    let mut messages = Vec::with_capacity(count);
    let samples = PyList::empty(py);
    for o in out {
        messages.push(o.message);
        if keep_samples {
            samples.append(samples_dict(py, o.samples, n, c)?)?;
        }
    }
    Ok(RunResult {
        status,
        messages,
        steps_done: steps.unbind(),
        initial_energies: initial.unbind(),
        max_deviation: deviation.unbind(),
        samples: keep_samples.then(|| samples.unbind()),
        interrupted,
        interrupted_by,
        info: PyDict::new(py).unbind(),
    })
}

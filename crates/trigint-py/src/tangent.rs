//! `tangent`: the tangent step of one trajectory (see `trigint_core::tangent`), its samples
//! returned as a dict of arrays.

use numpy::{PyArray1, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyDictMethods};
use std::sync::atomic::AtomicBool;

use trigint_core::{BatchLanes, Control, TangentRequest};

use crate::potential::{to_2d, with_potential};
use crate::{convert, handle, to_py, watch};

/// tangent(potential, layout, method, q0, p0, dq0, dp0, metric, n_steps, renormalize_every,
/// sample_every, progress_every, progress=None) -> dict
///
/// The trajectory of `integrate` from (q0, p0) with the K deviation vectors (rows of dq0,
/// dp0) carried by the tangent step, re-orthonormalized every `renormalize_every` steps (0:
/// never) in the metric `metric`. Returns `steps` (the samples' steps), `log_growth`
/// (samples × K: Σ ln R_jj), `megno` (⟨Y⟩ of the first vector), `dq`, `dp` (K × n, at the last
/// step), `q`, `p` (the state there), `steps_done`, `status` and `message`.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (potential, layout, method, q0, p0, dq0, dp0, metric, n_steps, renormalize_every, sample_every, progress_every, progress=None))]
pub fn tangent<'py>(
    py: Python<'py>,
    potential: &Bound<'py, PyAny>,
    layout: &Bound<'py, PyAny>,
    method: &Bound<'py, PyAny>,
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
    let given_layout = handle::given_layout(layout)?;
    let lay = given_layout.get();
    let given_method = handle::given_method(method)?;
    let co = given_method.get();
    let (q0, p0, metric) = (convert::vec1(q0), convert::vec1(p0), convert::vec1(metric));
    let k = dq0.as_array().nrows();
    let flat = |a: PyReadonlyArray2<f64>| a.as_array().iter().copied().collect::<Vec<f64>>();
    let (dq0, dp0) = (flat(dq0), flat(dp0));
    let request = TangentRequest {
        n_steps,
        renormalize_every,
        sample_every,
    };
    let mut pending: Option<PyErr> = None;
    let out = {
        let mut report = watch::reporter(&progress, &mut pending);
        py.detach(|| {
            let mut control = Control {
                every: progress_every.max(1),
                report: &mut report,
            };
            with_potential!(pot, |p| trigint_core::tangent(
                p,
                lay,
                co,
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
    let out = out.map_err(|e| to_py(e, pot))?;
    output_dict(py, out, k, q0.len(), pending)
}

/// A tangent run's output as the dict `tangent` returns.
pub(crate) fn output_dict(
    py: Python<'_>,
    out: trigint_core::TangentOutput,
    k: usize,
    n: usize,
    pending: Option<PyErr>,
) -> PyResult<Bound<'_, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("steps", PyArray1::from_slice(py, &out.steps))?;
    let rows = out.log_growth.len();
    let growth: Vec<f64> = out.log_growth.into_iter().flatten().collect();
    d.set_item("log_growth", to_2d(py, growth, rows, k)?)?;
    d.set_item("megno", PyArray1::from_slice(py, &out.megno))?;
    d.set_item("dq", to_2d(py, out.dq, k, n)?)?;
    d.set_item("dp", to_2d(py, out.dp, k, n)?)?;
    d.set_item("q", PyArray1::from_slice(py, &out.q))?;
    d.set_item("p", PyArray1::from_slice(py, &out.p))?;
    d.set_item("steps_done", out.steps_done)?;
    d.set_item("status", out.status.as_str())?;
    d.set_item("message", out.message)?;
    d.set_item("interrupted_by", pending.map(|e| e.to_string()))?;
    Ok(d)
}

/// tangent_batch(potential, layout, methods, q0, p0, n_steps, dq0, dp0, metric,
/// renormalize_every, threads=None) -> dict
///
/// `tangent` of every trajectory of a batch (rows of q0, p0; each its own method rows and step
/// count), from the same deviation vectors, sampled at the last step only, on a pool of
/// `threads` while this thread watches for Ctrl-C. Returns per trajectory `steps` (the step of
/// its last sample, 0 if none), `log_growth` (B × K there, NaN if none), `megno`, `steps_done`,
/// `status` and `message`, and `interrupted`.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (potential, layout, methods, q0, p0, n_steps, dq0, dp0, metric, renormalize_every, threads=None))]
pub fn tangent_batch<'py>(
    py: Python<'py>,
    potential: &Bound<'py, PyAny>,
    layout: &Bound<'py, PyAny>,
    methods: &Bound<'py, PyDict>,
    q0: PyReadonlyArray2<f64>,
    p0: PyReadonlyArray2<f64>,
    n_steps: Vec<u64>,
    dq0: PyReadonlyArray2<f64>,
    dp0: PyReadonlyArray2<f64>,
    metric: PyReadonlyArray1<f64>,
    renormalize_every: u64,
    threads: Option<usize>,
) -> PyResult<Bound<'py, PyDict>> {
    let given = handle::given(potential)?;
    let pot = given.get();
    let given_layout = handle::given_layout(layout)?;
    let lay = given_layout.get();
    let methods = convert::methods(methods)?;
    let k = dq0.as_array().nrows();
    let flat = |a: PyReadonlyArray2<f64>| a.as_array().iter().copied().collect::<Vec<f64>>();
    let (q0, p0, dq0, dp0) = (flat(q0), flat(p0), flat(dq0), flat(dp0));
    let metric = convert::vec1(metric);
    let stop = AtomicBool::new(false);
    let (outs, interrupted) = crate::on_pool(py, pot, threads, &stop, || {
        with_potential!(pot, |p| trigint_core::tangent_batch::<BatchLanes, _>(
            p,
            lay,
            &methods,
            &q0,
            &p0,
            &n_steps,
            (&dq0, &dp0),
            &metric,
            renormalize_every,
            &stop,
            4096,
        ))
    })?;
    let count = outs.len();
    let mut growth = vec![f64::NAN; count * k];
    let (mut steps, mut megno, mut done) =
        (vec![0u64; count], vec![f64::NAN; count], vec![0u64; count]);
    let (mut status, mut message) = (Vec::with_capacity(count), Vec::with_capacity(count));
    for (t, out) in outs.into_iter().enumerate() {
        if let (Some(&s), Some(g), Some(&y)) =
            (out.steps.last(), out.log_growth.last(), out.megno.last())
        {
            steps[t] = s;
            growth[t * k..(t + 1) * k].copy_from_slice(g);
            megno[t] = y;
        }
        done[t] = out.steps_done;
        status.push(out.status.as_str());
        message.push(out.message);
    }
    let d = PyDict::new(py);
    d.set_item("steps", PyArray1::from_slice(py, &steps))?;
    d.set_item("log_growth", to_2d(py, growth, count, k)?)?;
    d.set_item("megno", PyArray1::from_slice(py, &megno))?;
    d.set_item("steps_done", PyArray1::from_slice(py, &done))?;
    d.set_item("status", status)?;
    d.set_item("message", message)?;
    d.set_item("interrupted", interrupted)?;
    Ok(d)
}

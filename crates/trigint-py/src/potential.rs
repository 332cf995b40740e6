//! Potentials as the binding receives them, behind one dispatch: the core's native kinds
//! (built from their descriptions by the core, see `trigint_core::Native`) and Python callables.
//! A new native kind needs nothing here.

use std::sync::Mutex;

use numpy::{
    PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyKeyboardInterrupt, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use trigint_core::{CoreError, CoreResult, Native, Potential, Real, Scratch};

use crate::convert::{description, item};

pub enum NativePotential {
    Core(Native),
    Python(PythonCallbacks),
}

/// Runs `$body` with `$p` bound to the concrete potential: the one dispatch of the binding.
macro_rules! with_potential {
    ($pot:expr, |$p:ident| $body:expr) => {
        match $pot {
            $crate::potential::NativePotential::Core(native) => {
                trigint_core::with_native!(native, |$p| $body)
            }
            $crate::potential::NativePotential::Python($p) => $body,
        }
    };
}
pub(crate) use with_potential;

impl NativePotential {
    /// From a description: `{"kind": "python", "n", "value", "gradient", "vectorized"}` (Python
    /// callables), or any native kind's (`{"kind": "fpu", …}`, read by the core).
    pub fn from_spec(spec: &Bound<'_, PyDict>) -> PyResult<Self> {
        let kind: String = item(spec, "kind")?;
        if kind == "python" {
            return Ok(Self::Python(PythonCallbacks {
                dim: item(spec, "n")?,
                value: item::<Bound<'_, PyAny>>(spec, "value")?.unbind(),
                gradient: item::<Bound<'_, PyAny>>(spec, "gradient")?.unbind(),
                vectorized: item(spec, "vectorized")?,
                hessian_vector: spec
                    .get_item("hessian_vector")?
                    .filter(|h| !h.is_none())
                    .map(|h| h.unbind()),
                finite_differences: spec
                    .get_item("finite_differences")?
                    .map(|b| b.extract::<bool>())
                    .transpose()?
                    .unwrap_or(false),
                error: Mutex::new(None),
            }));
        }
        if !Native::KINDS.contains(&kind.as_str()) {
            return Err(PyValueError::new_err(format!(
                "unknown potential kind {kind:?}; expected one of {}, python",
                Native::KINDS.join(", ")
            )));
        }
        let d = description(spec.as_any())?;
        Native::from_description(&d)
            .map(Self::Core)
            .map_err(|e| PyValueError::new_err(e.to_string()))
    }

    /// The Python exception raised inside a callback, if any (not a Ctrl-C, which interrupts).
    pub fn take_error(&self) -> Option<PyErr> {
        match self {
            Self::Python(p) => p.error.lock().ok()?.take(),
            _ => None,
        }
    }

    /// Instructions of the force-only code of a compiled program (None for other kinds).
    pub fn instructions(&self) -> Option<usize> {
        match self {
            Self::Core(p) => p.instructions(),
            Self::Python(_) => None,
        }
    }
}

/// U and ∇U as Python callables: of a 1-d array (one call per trajectory), or, vectorized, of
/// a 2-d array (lanes, n) whose rows are trajectories (one call per bundle of lanes).
pub struct PythonCallbacks {
    dim: usize,
    value: Py<PyAny>,
    gradient: Py<PyAny>,
    vectorized: bool,
    /// The user's Hessian–vector product (x, v) ↦ ∇²U(x) v, for the tangent map.
    hessian_vector: Option<Py<PyAny>>,
    /// Without one: whether the tangent map may difference the gradient instead.
    finite_differences: bool,
    error: Mutex<Option<PyErr>>,
}

impl PythonCallbacks {
    pub fn vectorized(&self) -> bool {
        self.vectorized
    }

    /// Keeps the first exception for the caller; a Ctrl-C becomes an interruption.
    fn fail(&self, py: Python<'_>, e: PyErr) -> CoreError {
        if e.is_instance_of::<PyKeyboardInterrupt>(py) {
            return CoreError::Interrupted;
        }
        let msg = e.to_string();
        if let Ok(mut slot) = self.error.lock() {
            slot.get_or_insert(e);
        }
        CoreError::Potential(msg)
    }

    /// The states of the lanes as the callables take them, with non-finite entries (of lanes
    /// that have ended) replaced by 0 so that user code never sees them: lane by lane for
    /// per-trajectory calls, coordinate by coordinate (the kernel's order) when vectorized.
    fn states<L: Real>(&self, x: &[L]) -> Vec<f64> {
        let clean = |s: f64| if s.is_finite() { s } else { 0.0 };
        let (n, lanes) = (x.len(), L::LANES);
        if self.vectorized {
            if let Some(flat) = L::as_f64s(x) {
                return flat.iter().map(|&s| clean(s)).collect();
            }
        }
        let mut out = vec![0.0; lanes * n];
        for (i, v) in x.iter().enumerate() {
            for b in 0..lanes {
                let at = if self.vectorized {
                    i * lanes + b
                } else {
                    b * n + i
                };
                out[at] = clean(v.lane(b));
            }
        }
        out
    }

    /// The (lanes, n) block of the vectorized callables, column-major: each coordinate is
    /// contiguous across the rows, so NumPy's loops over a column run over all lanes at once.
    fn block<'py>(py: Python<'py>, states: &[f64], lanes: usize) -> PyResult<Bound<'py, PyAny>> {
        let n = states.len() / lanes;
        let arr = PyArray1::from_slice(py, states).reshape([n, lanes])?;
        Ok(arr.transpose()?.into_any())
    }

    /// U of each lane.
    fn call_value(&self, py: Python<'_>, states: &[f64], lanes: usize) -> PyResult<Vec<f64>> {
        let n = states.len() / lanes;
        if self.vectorized {
            let r = self.value.call1(py, (Self::block(py, states, lanes)?,))?;
            let v: PyReadonlyArray1<f64> = r.bind(py).extract().map_err(|_| {
                PyTypeError::new_err(format!(
                    "the vectorized value function must return {lanes} floats (one per row), got {}",
                    returned(r.bind(py))
                ))
            })?;
            if v.len() != lanes {
                return Err(PyValueError::new_err(format!(
                    "the vectorized value function returned {} values for {lanes} rows",
                    v.len()
                )));
            }
            return Ok(v.as_array().to_vec());
        }
        (0..lanes)
            .map(|b| {
                let arr = PyArray1::from_slice(py, &states[b * n..(b + 1) * n]);
                let r = self.value.call1(py, (arr,))?;
                r.extract::<f64>(py).map_err(|_| {
                    PyTypeError::new_err(format!(
                        "the value function must return one float, got {}",
                        returned(r.bind(py))
                    ))
                })
            })
            .collect()
    }

    /// −∇U of each lane, into `force`.
    fn call_gradient<L: Real>(
        &self,
        py: Python<'_>,
        states: &[f64],
        force: &mut [L],
    ) -> PyResult<()> {
        let (n, lanes) = (force.len(), L::LANES);
        if self.vectorized {
            let r = self
                .gradient
                .call1(py, (Self::block(py, states, lanes)?,))?;
            let g: PyReadonlyArray2<f64> = r.bind(py).extract().map_err(|_| {
                PyTypeError::new_err(format!(
                    "the vectorized gradient must return a float array of shape ({lanes}, {n}), got {}",
                    returned(r.bind(py))
                ))
            })?;
            if g.shape() != [lanes, n] {
                return Err(PyValueError::new_err(format!(
                    "the vectorized gradient returned shape {:?}, expected ({lanes}, {n})",
                    g.shape()
                )));
            }
            let g = g.as_array();
            // A column-major result (NumPy keeps the block's order) is the kernel's order.
            if let (Some(src), Some(dst)) = (g.t().to_slice(), L::as_f64s_mut(force)) {
                for (d, s) in dst.iter_mut().zip(src) {
                    *d = -s;
                }
                return Ok(());
            }
            for (i, f) in force.iter_mut().enumerate() {
                for (b, x) in g.column(i).iter().enumerate() {
                    f.set_lane(b, -x);
                }
            }
            return Ok(());
        }
        for b in 0..lanes {
            let arr = PyArray1::from_slice(py, &states[b * n..(b + 1) * n]);
            let r = self.gradient.call1(py, (arr,))?;
            let g: PyReadonlyArray1<f64> = r.bind(py).extract().map_err(|_| {
                PyTypeError::new_err(format!(
                    "the gradient must return a 1-d float array of {n} values, got {}",
                    returned(r.bind(py))
                ))
            })?;
            if g.len() != n {
                return Err(PyValueError::new_err(format!(
                    "the gradient returned {} values for {n} coordinates",
                    g.len()
                )));
            }
            for (f, x) in force.iter_mut().zip(g.as_array().iter()) {
                f.set_lane(b, -x);
            }
        }
        Ok(())
    }
}

impl Potential for PythonCallbacks {
    type Workspace<L: Real> = ();
    const SPECIALIZE: bool = false;

    fn dim(&self) -> usize {
        self.dim
    }

    fn workspace<L: Real>(&self) {}

    fn force<L: Real>(
        &self,
        x: &[L],
        force: &mut [L],
        with_value: bool,
        _: &mut (),
    ) -> CoreResult<L> {
        let states = self.states(x);
        Python::attach(|py| {
            self.call_gradient(py, &states, force)
                .map_err(|e| self.fail(py, e))?;
            let mut u = L::zero();
            if with_value {
                let v = self
                    .call_value(py, &states, L::LANES)
                    .map_err(|e| self.fail(py, e))?;
                for (b, x) in v.iter().enumerate() {
                    u.set_lane(b, *x);
                }
            }
            Ok(u)
        })
    }

    /// The user's ∇²U(x)v (negated), or, where allowed, the central difference
    /// (g(x + εv) − g(x − εv))/(2ε) with ε = ∛(machine ε)·(1 + ‖x‖)/‖v‖.
    fn force_derivative(
        &self,
        x: &[f64],
        v: &[f64],
        out: &mut [f64],
        ws: &mut (),
        s: &mut Scratch,
    ) -> CoreResult<()> {
        let n = self.dim;
        if let Some(hvp) = &self.hessian_vector {
            return Python::attach(|py| {
                let mut call = || -> PyResult<()> {
                    let r = hvp.call1(
                        py,
                        (PyArray1::from_slice(py, x), PyArray1::from_slice(py, v)),
                    )?;
                    let hv: PyReadonlyArray1<f64> = r.bind(py).extract().map_err(|_| {
                        PyTypeError::new_err(format!(
                            "hessian_vector must return a 1-d float array of {n} values, got {}",
                            returned(r.bind(py))
                        ))
                    })?;
                    if hv.len() != n {
                        return Err(PyValueError::new_err(format!(
                            "hessian_vector returned {} values for {n} coordinates",
                            hv.len()
                        )));
                    }
                    for (o, h) in out.iter_mut().zip(hv.as_array().iter()) {
                        *o = -h;
                    }
                    Ok(())
                };
                call().map_err(|e| self.fail(py, e))
            });
        }
        if !self.finite_differences {
            return Err(CoreError::invalid(
                "potential",
                "this PythonPotential has no hessian_vector (x, v) -> Hess U(x) v, which the \
                 tangent map needs; give one, or allow central differences of the gradient \
                 (finite_differences=True)",
            ));
        }
        let norm = |y: &[f64]| y.iter().map(|a| a * a).sum::<f64>().sqrt();
        let vn = norm(v);
        if vn == 0.0 {
            out.fill(0.0);
            return Ok(());
        }
        let eps = f64::EPSILON.cbrt() * (1.0 + norm(x)) / vn;
        let plus = Scratch::sized(&mut s.a, n);
        for i in 0..n {
            plus[i] = x[i] + eps * v[i];
        }
        let minus = Scratch::sized(&mut s.b, n);
        for i in 0..n {
            minus[i] = x[i] - eps * v[i];
        }
        let gp = Scratch::sized(&mut s.c, n);
        self.force(&s.a, gp, false, ws)?;
        self.force(&s.b, out, false, ws)?;
        for (o, g) in out.iter_mut().zip(&s.c) {
            *o = (g - *o) / (2.0 * eps);
        }
        Ok(())
    }

    fn value<L: Real>(&self, x: &[L], _: &mut ()) -> CoreResult<L> {
        let states = self.states(x);
        Python::attach(|py| {
            let v = self
                .call_value(py, &states, L::LANES)
                .map_err(|e| self.fail(py, e))?;
            let mut u = L::zero();
            for (b, x) in v.iter().enumerate() {
                u.set_lane(b, *x);
            }
            Ok(u)
        })
    }
}

/// What a user's callable returned, as its error names it: the type, and for an array its dtype
/// and shape (`list`, `ndarray of dtype int64 and shape (6,)`).
fn returned(r: &Bound<'_, PyAny>) -> String {
    let kind = r
        .get_type()
        .name()
        .map(|n| n.to_string())
        .unwrap_or_else(|_| "an object".to_string());
    match (r.getattr("dtype"), r.getattr("shape")) {
        (Ok(dtype), Ok(shape)) => format!("{kind} of dtype {dtype} and shape {shape}"),
        _ => kind,
    }
}

/// U at each row of x (m × n), and −∇U, through the core's evaluation (for tests and for
/// evaluating potentials on data).
pub fn values_and_forces<P: Potential>(
    pot: &P,
    x: &[f64],
    rows: usize,
    n: usize,
) -> CoreResult<(Vec<f64>, Vec<f64>)> {
    pot.check_dim(n)?;
    let mut ws = pot.workspace::<f64>();
    let (mut values, mut forces) = (vec![0.0; rows], vec![0.0; rows * n]);
    for r in 0..rows {
        values[r] = pot.force(
            &x[r * n..(r + 1) * n],
            &mut forces[r * n..(r + 1) * n],
            true,
            &mut ws,
        )?;
    }
    Ok((values, forces))
}

/// The (m, n) array of row-major data.
pub fn to_2d<'py>(
    py: Python<'py>,
    data: Vec<f64>,
    rows: usize,
    cols: usize,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    PyArray1::from_vec(py, data).reshape([rows, cols])
}

//! Potentials as the binding receives them: a spec tuple from Python, turned into a core
//! potential. Python callbacks re-attach to the interpreter for each evaluation and keep
//! the first exception they raise so that it reaches the user unchanged.

use std::sync::Mutex;

use numpy::{PyArray1, PyReadonlyArray1, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use trigint_core::{
    CoreError, CoreResult, EnergyLayout, Fpu, MethodCoefficients, Polynomial, Potential, RunOutput,
    RunSpec,
};

pub(crate) enum NativePotential {
    Fpu(Fpu),
    Polynomial(Polynomial),
    Python(PythonCallbacks),
}

impl NativePotential {
    /// ("fpu", m) | ("polynomial", dim, coefficients, exponents) | ("python", dim, value, gradient)
    pub fn from_spec(spec: &Bound<'_, PyAny>) -> PyResult<Self> {
        let kind: String = spec.get_item(0)?.extract()?;
        let err = |e: CoreError| PyValueError::new_err(e.to_string());
        match kind.as_str() {
            "fpu" => Ok(NativePotential::Fpu(
                Fpu::new(spec.get_item(1)?.extract()?).map_err(err)?,
            )),
            "polynomial" => {
                let dim: usize = spec.get_item(1)?.extract()?;
                let coefficients: Vec<f64> = spec.get_item(2)?.extract()?;
                let exponents: Vec<i64> = spec.get_item(3)?.extract()?;
                Ok(NativePotential::Polynomial(
                    Polynomial::new(dim, coefficients, &exponents).map_err(err)?,
                ))
            }
            "python" => Ok(NativePotential::Python(PythonCallbacks {
                dim: spec.get_item(1)?.extract()?,
                value: spec.get_item(2)?.unbind(),
                gradient: spec.get_item(3)?.unbind(),
                error: Mutex::new(None),
            })),
            other => Err(PyValueError::new_err(format!(
                "unknown potential kind {other:?}"
            ))),
        }
    }

    /// The Python exception raised inside a callback, if any.
    pub fn take_error(&self) -> Option<PyErr> {
        match self {
            NativePotential::Python(p) => p.error.lock().ok()?.take(),
            _ => None,
        }
    }

    pub fn integrate(
        &self,
        co: &MethodCoefficients,
        lay: &EnergyLayout,
        q0: &[f64],
        p0: &[f64],
        spec: &RunSpec,
        progress: &mut dyn FnMut(u64) -> bool,
    ) -> CoreResult<RunOutput> {
        match self {
            NativePotential::Fpu(p) => trigint_core::integrate(p, co, lay, q0, p0, spec, progress),
            NativePotential::Polynomial(p) => {
                trigint_core::integrate(p, co, lay, q0, p0, spec, progress)
            }
            NativePotential::Python(p) => {
                trigint_core::integrate(p, co, lay, q0, p0, spec, progress)
            }
        }
    }

    #[allow(clippy::too_many_arguments)]
    pub fn integrate_batch(
        &self,
        methods: &[trigint_core::TrajectoryMethod],
        lay: &EnergyLayout,
        q0: &[f64],
        p0: &[f64],
        n_steps: &[u64],
        spec: &trigint_core::BatchSpec,
        stop: &std::sync::atomic::AtomicBool,
    ) -> CoreResult<Vec<trigint_core::TrajectoryOutput>> {
        match self {
            NativePotential::Fpu(p) => {
                trigint_core::integrate_batch(p, methods, lay, q0, p0, n_steps, spec, stop)
            }
            NativePotential::Polynomial(p) => {
                trigint_core::integrate_batch(p, methods, lay, q0, p0, n_steps, spec, stop)
            }
            NativePotential::Python(p) => {
                trigint_core::integrate_batch(p, methods, lay, q0, p0, n_steps, spec, stop)
            }
        }
    }

    fn as_dyn(&self) -> &dyn Potential {
        match self {
            NativePotential::Fpu(p) => p,
            NativePotential::Polynomial(p) => p,
            NativePotential::Python(p) => p,
        }
    }

    pub fn values(&self, x: &[f64], m: usize, n: usize) -> CoreResult<Vec<f64>> {
        let p = self.as_dyn();
        p.check_dim(n)?;
        (0..m).map(|r| p.value(&x[r * n..(r + 1) * n])).collect()
    }

    pub fn forces(&self, x: &[f64], m: usize, n: usize) -> CoreResult<Vec<f64>> {
        let p = self.as_dyn();
        p.check_dim(n)?;
        let mut out = vec![0.0; m * n];
        for r in 0..m {
            p.force(&x[r * n..(r + 1) * n], &mut out[r * n..(r + 1) * n])?;
        }
        Ok(out)
    }
}

/// U and ∇U given as Python callables of a 1-d NumPy array.
pub(crate) struct PythonCallbacks {
    dim: usize,
    value: Py<PyAny>,
    gradient: Py<PyAny>,
    error: Mutex<Option<PyErr>>,
}

impl PythonCallbacks {
    fn fail(&self, e: PyErr) -> CoreError {
        let msg = e.to_string();
        if let Ok(mut slot) = self.error.lock() {
            slot.get_or_insert(e);
        }
        CoreError::Potential(msg)
    }
}

impl Potential for PythonCallbacks {
    fn dim(&self) -> usize {
        self.dim
    }

    fn value(&self, x: &[f64]) -> CoreResult<f64> {
        Python::attach(|py| {
            let arr = PyArray1::from_slice(py, x);
            self.value
                .call1(py, (arr,))
                .and_then(|r| r.extract::<f64>(py))
                .map_err(|e| self.fail(e))
        })
    }

    fn force(&self, x: &[f64], f: &mut [f64]) -> CoreResult<()> {
        Python::attach(|py| {
            let arr = PyArray1::from_slice(py, x);
            let result = self.gradient.call1(py, (arr,)).map_err(|e| self.fail(e))?;
            let grad: PyReadonlyArray1<f64> = result.bind(py).extract().map_err(|_| {
                self.fail(PyValueError::new_err(
                    "the gradient must return a 1-d float array",
                ))
            })?;
            if grad.len() != f.len() {
                return Err(self.fail(PyValueError::new_err(format!(
                    "the gradient returned {} values for {} coordinates",
                    grad.len(),
                    f.len()
                ))));
            }
            for (fi, gi) in f.iter_mut().zip(grad.as_array().iter()) {
                *fi = -gi;
            }
            Ok(())
        })
    }
}

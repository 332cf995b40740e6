//! `_core.Potential`: a potential built (its tape compiled to machine code, its FFTs planned)
//! once and passed to every entry point instead of its description; `_core.Layout`: a problem's
//! arrangement converted once (a wave equation's has tens of thousands of blocks and pairs).
//! `_core.Method`: a method's per-coordinate numbers converted once (a wave equation's are eight
//! rows of tens of thousands). All pickle as their descriptions, so a worker process builds them
//! once per chunk as before.

use numpy::{PyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use trigint_core::{Layout, MethodCoefficients};

use crate::convert;
use crate::potential::{to_2d, values_and_forces, with_potential, NativePotential};
use crate::{to_py, ValuesAndForces};

/// Potential(spec): the potential of a description (`{"kind": …}`), built once.
#[pyclass(frozen, module = "trigint._core", name = "Potential")]
pub struct Handle {
    pub pot: NativePotential,
    spec: Py<PyDict>,
}

/// The potential an entry point was given: a handle (built already) or a description (built
/// here, for this call).
pub enum Given<'py> {
    Built(Bound<'py, Handle>),
    Described(Box<NativePotential>),
}

impl Given<'_> {
    pub fn get(&self) -> &NativePotential {
        match self {
            Given::Built(h) => &h.get().pot,
            Given::Described(p) => p,
        }
    }
}

/// A `_core.Potential` or a description dict.
pub fn given<'py>(obj: &Bound<'py, PyAny>) -> PyResult<Given<'py>> {
    if let Ok(h) = obj.cast::<Handle>() {
        return Ok(Given::Built(h.clone()));
    }
    let spec = obj.cast::<PyDict>()?;
    Ok(Given::Described(Box::new(NativePotential::from_spec(
        spec,
    )?)))
}

#[pymethods]
impl Handle {
    #[new]
    fn new(spec: &Bound<'_, PyDict>) -> PyResult<Self> {
        Ok(Handle {
            pot: NativePotential::from_spec(spec)?,
            spec: spec.clone().unbind(),
        })
    }

    /// evaluate(x) -> (U at each row of x (m, n), −∇U at each row)
    fn evaluate<'py>(
        &self,
        py: Python<'py>,
        x: PyReadonlyArray2<f64>,
    ) -> PyResult<ValuesAndForces<'py>> {
        let (m, n) = (x.shape()[0], x.shape()[1]);
        let data: Vec<f64> = x.as_array().iter().copied().collect();
        let pot = &self.pot;
        let r = py.detach(|| with_potential!(pot, |p| values_and_forces(p, &data, m, n)));
        let (v, f) = r.map_err(|e| to_py(e, pot))?;
        Ok((PyArray1::from_vec(py, v), to_2d(py, f, m, n)?))
    }

    /// Instructions of a compiled program's force code (None for other kinds).
    fn instructions(&self) -> Option<usize> {
        self.pot.instructions()
    }

    /// The description it was built from.
    #[getter]
    fn spec<'py>(&self, py: Python<'py>) -> Bound<'py, PyDict> {
        self.spec.bind(py).clone()
    }

    fn __reduce__<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyAny>, (Bound<'py, PyDict>,))> {
        Ok((
            py.get_type::<Handle>().into_any(),
            (self.spec.bind(py).clone(),),
        ))
    }
}

/// Layout(spec): a problem's arrangement (`{"omega2", "n_slow", "block_ends", "pair_forms"}`),
/// converted once.
#[pyclass(frozen, module = "trigint._core", name = "Layout")]
pub struct LayoutHandle {
    pub layout: Layout,
    spec: Py<PyDict>,
}

/// The layout an entry point was given: a handle (converted already) or a description.
pub enum GivenLayout<'py> {
    Built(Bound<'py, LayoutHandle>),
    Described(Box<Layout>),
}

impl GivenLayout<'_> {
    pub fn get(&self) -> &Layout {
        match self {
            GivenLayout::Built(h) => &h.get().layout,
            GivenLayout::Described(l) => l,
        }
    }
}

/// A `_core.Layout` or a description dict.
pub fn given_layout<'py>(obj: &Bound<'py, PyAny>) -> PyResult<GivenLayout<'py>> {
    if let Ok(h) = obj.cast::<LayoutHandle>() {
        return Ok(GivenLayout::Built(h.clone()));
    }
    Ok(GivenLayout::Described(Box::new(convert::layout(
        obj.cast::<PyDict>()?,
    )?)))
}

#[pymethods]
impl LayoutHandle {
    #[new]
    fn new(spec: &Bound<'_, PyDict>) -> PyResult<Self> {
        Ok(LayoutHandle {
            layout: convert::layout(spec)?,
            spec: spec.clone().unbind(),
        })
    }

    /// The description it was converted from.
    #[getter]
    fn spec<'py>(&self, py: Python<'py>) -> Bound<'py, PyDict> {
        self.spec.bind(py).clone()
    }

    fn __reduce__<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyAny>, (Bound<'py, PyDict>,))> {
        Ok((
            py.get_type::<LayoutHandle>().into_any(),
            (self.spec.bind(py).clone(),),
        ))
    }
}

/// Method(spec): one method's numbers (`{"h": float, <row>: 1-d array, …}`), converted once.
#[pyclass(frozen, module = "trigint._core", name = "Method")]
pub struct MethodHandle {
    pub method: MethodCoefficients,
    spec: Py<PyDict>,
}

/// The method an entry point was given: a handle (converted already) or a description.
pub enum GivenMethod<'py> {
    Built(Bound<'py, MethodHandle>),
    Described(Box<MethodCoefficients>),
}

impl GivenMethod<'_> {
    pub fn get(&self) -> &MethodCoefficients {
        match self {
            GivenMethod::Built(h) => &h.get().method,
            GivenMethod::Described(m) => m,
        }
    }
}

/// A `_core.Method` or a description dict.
pub fn given_method<'py>(obj: &Bound<'py, PyAny>) -> PyResult<GivenMethod<'py>> {
    if let Ok(h) = obj.cast::<MethodHandle>() {
        return Ok(GivenMethod::Built(h.clone()));
    }
    Ok(GivenMethod::Described(Box::new(convert::method(
        obj.cast::<PyDict>()?,
    )?)))
}

#[pymethods]
impl MethodHandle {
    #[new]
    fn new(spec: &Bound<'_, PyDict>) -> PyResult<Self> {
        Ok(MethodHandle {
            method: convert::method(spec)?,
            spec: spec.clone().unbind(),
        })
    }

    /// The description it was converted from.
    #[getter]
    fn spec<'py>(&self, py: Python<'py>) -> Bound<'py, PyDict> {
        self.spec.bind(py).clone()
    }

    fn __reduce__<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyAny>, (Bound<'py, PyDict>,))> {
        Ok((
            py.get_type::<MethodHandle>().into_any(),
            (self.spec.bind(py).clone(),),
        ))
    }
}

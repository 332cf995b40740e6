//! `_core.Potential`: a potential built (its tape compiled to machine code, its FFTs planned)
//! once and passed to every entry point instead of its description; `_core.Layout`: a problem's
//! arrangement converted once (a wave equation's has tens of thousands of blocks and pairs).
//! `_core.Method`: a method's per-coordinate numbers converted once (a wave equation's are eight
//! rows of tens of thousands). Layouts and methods are checked once, and a method keeps the
//! kernels' rows made from it ([`trigint_core::prepared`]). All pickle as their descriptions, so a worker process builds them
//! once per chunk as before.

use numpy::{PyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use trigint_core::{PreparedLayout, PreparedMethod};

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

/// A layout converted once, whose checks then pass once for every run it is given to.
fn prepared_layout(spec: &Bound<'_, PyDict>) -> PyResult<PreparedLayout> {
    convert::layout(spec).map(PreparedLayout::new)
}

/// A method converted once, whose checks pass once per size and form and whose kernel rows
/// are made once (kept for the next run).
fn prepared_method(spec: &Bound<'_, PyDict>) -> PyResult<PreparedMethod> {
    convert::method(spec).map(PreparedMethod::new)
}

/// A class holding a value converted once from its description dict (by `$convert`), pickled
/// as the description, with the enum and function by which an entry point takes either it or a
/// description (converted then, for that call).
macro_rules! converted_handle {
    ($(#[$doc:meta])* $handle:ident, $py_name:tt, $value:ty, $convert:path, $given_enum:ident,
     $given:ident) => {
        $(#[$doc])*
        #[pyclass(frozen, module = "trigint._core", name = $py_name)]
        pub struct $handle {
            pub value: $value,
            spec: Py<PyDict>,
        }

        /// What an entry point was given: a handle (converted already) or a description.
        pub enum $given_enum<'py> {
            Built(Bound<'py, $handle>),
            Described(Box<$value>),
        }

        impl $given_enum<'_> {
            pub fn get(&self) -> &$value {
                match self {
                    Self::Built(h) => &h.get().value,
                    Self::Described(v) => v,
                }
            }
        }

        /// The handle, or a description dict converted for this call.
        pub fn $given<'py>(obj: &Bound<'py, PyAny>) -> PyResult<$given_enum<'py>> {
            if let Ok(h) = obj.cast::<$handle>() {
                return Ok($given_enum::Built(h.clone()));
            }
            Ok($given_enum::Described(Box::new($convert(
                obj.cast::<PyDict>()?,
            )?)))
        }

        #[pymethods]
        impl $handle {
            #[new]
            fn new(spec: &Bound<'_, PyDict>) -> PyResult<Self> {
                Ok($handle {
                    value: $convert(spec)?,
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
                    py.get_type::<$handle>().into_any(),
                    (self.spec.bind(py).clone(),),
                ))
            }
        }
    };
}

converted_handle!(
    /// Layout(spec): a problem's arrangement (`{"omega2", "n_slow", "block_ends",
    /// "pair_forms"}`), converted once.
    LayoutHandle,
    "Layout",
    PreparedLayout,
    prepared_layout,
    GivenLayout,
    given_layout
);

converted_handle!(
    /// Method(spec): one method's numbers (`{"h": float, <row>: 1-d array, …}`), converted
    /// once.
    MethodHandle,
    "Method",
    PreparedMethod,
    prepared_method,
    GivenMethod,
    given_method
);

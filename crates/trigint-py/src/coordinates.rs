//! `_core.CoordinateMap`: the core's map between a problem's user coordinates and its own
//! (`trigint_core::coordinates`), applied to states in and out and composed with potentials'
//! input maps.

use std::borrow::Cow;
use std::sync::Arc;

use numpy::{
    PyArray1, PyArrayDyn, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArrayDyn,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use trigint_core::coordinates::{self, SparseMap};

use crate::convert::item;
use crate::grid::FourierGrid;

fn value_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// Indices of a permutation; a negative one is refused here, with its value.
fn indices(a: &PyReadonlyArray1<'_, i64>, what: &str) -> PyResult<Vec<usize>> {
    a.as_array()
        .iter()
        .map(|&k| {
            usize::try_from(k).map_err(|_| {
                PyValueError::new_err(format!(
                    "{what}: must be a permutation of 0..{}; {k} is out of range",
                    a.len()
                ))
            })
        })
        .collect()
}

/// CoordinateMap: how the core's coordinates are made from the user's. Built by
/// `CoordinateMap.identity(n)`, `.permuted(perm)` (core coordinate k is user coordinate
/// perm[k]), `.modal(basis)` (q = Q x) or `.fourier(grid, order)` (q = Sᵀu / N, in `order`).
#[pyclass(frozen, module = "trigint._core")]
pub struct CoordinateMap {
    map: Arc<coordinates::CoordinateMap>,
    /// What rebuilds it (for pickling): the constructor's name and its argument.
    made_by: (&'static str, Py<PyAny>),
}

impl CoordinateMap {
    fn made(map: coordinates::CoordinateMap, how: &'static str, arg: Bound<'_, PyAny>) -> Self {
        CoordinateMap {
            map: Arc::new(map),
            made_by: (how, arg.unbind()),
        }
    }

    /// `f(rows, out)` over the rows of `x` (any array-like of floats; last axis: the map's
    /// coordinates), an array of the same shape out.
    fn apply<'py>(
        &self,
        py: Python<'py>,
        x: &Bound<'py, PyAny>,
        f: fn(&coordinates::CoordinateMap, &[f64], &mut [f64]),
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        let x: PyReadonlyArrayDyn<'py, f64> = match x.extract() {
            Ok(a) => a,
            Err(_) => py
                .import("numpy")?
                .call_method1("asarray", (x, "float64"))?
                .extract()?,
        };
        let n = self.map.dim();
        let shape = x.shape().to_vec();
        if shape.last() != Some(&n) {
            return Err(PyValueError::new_err(format!(
                "expected states of {n} coordinates along the last axis, got shape {shape:?}"
            )));
        }
        // (`as_slice` also takes a column-major array, in its memory order: rows are wanted)
        let data = match x.as_slice() {
            Ok(s) if x.is_c_contiguous() => Cow::Borrowed(s),
            _ => Cow::Owned(x.as_array().iter().copied().collect()),
        };
        let mut out = vec![0.0; data.len()];
        let map = &*self.map;
        py.detach(|| f(map, &data, &mut out));
        PyArray1::from_vec(py, out).reshape(shape)
    }
}

#[pymethods]
impl CoordinateMap {
    #[staticmethod]
    fn identity(py: Python<'_>, n: usize) -> PyResult<Self> {
        let arg = n.into_pyobject(py)?.into_any();
        Ok(Self::made(
            coordinates::CoordinateMap::Identity { n },
            "identity",
            arg,
        ))
    }

    #[staticmethod]
    fn permuted<'py>(perm: PyReadonlyArray1<'py, i64>) -> PyResult<Self> {
        let p = indices(&perm, "perm")?;
        let map = coordinates::CoordinateMap::permuted(p).map_err(value_error)?;
        Ok(Self::made(map, "permuted", perm.as_any().clone()))
    }

    #[staticmethod]
    fn modal<'py>(basis: PyReadonlyArray2<'py, f64>) -> PyResult<Self> {
        let n = basis.shape()[0];
        if basis.shape()[1] != n {
            return Err(PyValueError::new_err(format!(
                "basis: expected a square matrix, got shape {:?}",
                basis.shape()
            )));
        }
        let q: Vec<f64> = basis.as_array().iter().copied().collect();
        let map = coordinates::CoordinateMap::modal(n, q).map_err(value_error)?;
        Ok(Self::made(map, "modal", basis.as_any().clone()))
    }

    #[staticmethod]
    fn fourier<'py>(
        py: Python<'py>,
        grid: Bound<'py, FourierGrid>,
        order: PyReadonlyArray1<'py, i64>,
    ) -> PyResult<Self> {
        let o = indices(&order, "order")?;
        let map = coordinates::CoordinateMap::fourier(Arc::clone(&grid.get().grid), o)
            .map_err(value_error)?;
        let arg = (grid, order.as_any().clone()).into_pyobject(py)?.into_any();
        Ok(Self::made(map, "fourier", arg))
    }

    /// "identity", "permuted", "modal" or "fourier".
    #[getter]
    fn kind(&self) -> &'static str {
        self.map.kind()
    }

    /// Coordinates per state.
    #[getter]
    fn dim(&self) -> usize {
        self.map.dim()
    }

    /// Q of a modal map (q = Q x), else None.
    #[getter]
    fn basis<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyAny>> {
        let (how, arg) = &self.made_by;
        (*how == "modal").then(|| arg.bind(py).clone())
    }

    #[getter]
    fn is_identity(&self) -> bool {
        self.map.is_identity()
    }

    /// to_core(x) -> the states x (user coordinates along the last axis) in the core's.
    fn to_core<'py>(
        &self,
        py: Python<'py>,
        x: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        self.apply(py, x, coordinates::CoordinateMap::to_core)
    }

    /// to_user(x) -> the states x (core coordinates along the last axis) in the user's.
    fn to_user<'py>(
        &self,
        py: Python<'py>,
        x: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        self.apply(py, x, coordinates::CoordinateMap::to_user)
    }

    /// to_user_in_place(x, first, done=None) -> None: rows first, first + 1, … of x (a
    /// writeable, C-contiguous float64 array; last axis: the core's coordinates) taken to the
    /// user's coordinates in place, a row at a time through a copy, except the rows r with
    /// done[r] (in the user's coordinates already). A run's samples are made so, with no second
    /// array of their size.
    #[pyo3(signature = (x, first, done=None))]
    fn to_user_in_place(
        &self,
        py: Python<'_>,
        x: &Bound<'_, PyArrayDyn<f64>>,
        first: usize,
        done: Option<PyReadonlyArray1<'_, bool>>,
    ) -> PyResult<()> {
        let n = self.map.dim();
        let shape = x.shape().to_vec();
        if shape.last() != Some(&n) {
            return Err(PyValueError::new_err(format!(
                "expected states of {n} coordinates along the last axis, got shape {shape:?}"
            )));
        }
        // (`as_slice_mut` also takes a column-major array, in its memory order: rows are wanted)
        if !x.is_c_contiguous() {
            return Err(PyValueError::new_err(
                "x: not a C-contiguous array; use to_user",
            ));
        }
        let mut x = x.try_readwrite().map_err(|e| {
            PyValueError::new_err(format!("x: not a writeable array ({e}); use to_user"))
        })?;
        let rows = x.as_slice_mut().map_err(|_| {
            PyValueError::new_err("x: not a C-contiguous array; use to_user".to_string())
        })?;
        let done = done
            .as_ref()
            .map(|d| d.as_array().to_vec())
            .unwrap_or_default();
        let count = rows.len() / n.max(1);
        if !done.is_empty() && done.len() != count {
            return Err(PyValueError::new_err(format!(
                "done: one flag per row expected ({count}), got {}",
                done.len()
            )));
        }
        let map = &*self.map;
        py.detach(|| {
            let mut row = vec![0.0; n];
            for (r, out) in rows.chunks_exact_mut(n.max(1)).enumerate().skip(first) {
                if done.get(r) == Some(&true) {
                    continue;
                }
                row.copy_from_slice(out);
                map.to_user(&row, out);
            }
        });
        Ok(())
    }

    /// numbers_to_core(x) -> per-coordinate numbers listed in the order of the problem's
    /// frequencies (a method's coefficients) in the core's order.
    fn numbers_to_core<'py>(
        &self,
        py: Python<'py>,
        x: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        self.apply(py, x, coordinates::CoordinateMap::numbers_to_core)
    }

    /// compose(m, rows) -> the input map m of a potential (a dict {"rows", "cols", "ptr",
    /// "idx", "vals"} reading user coordinates; None: the first `rows` coordinates) as a map
    /// of the core's coordinates, in the same form.
    #[pyo3(signature = (m, rows))]
    fn compose<'py>(
        &self,
        py: Python<'py>,
        m: Option<Bound<'py, PyDict>>,
        rows: usize,
    ) -> PyResult<Bound<'py, PyDict>> {
        let given = match m {
            Some(d) => Some(
                SparseMap {
                    rows: item(&d, "rows")?,
                    cols: item(&d, "cols")?,
                    ptr: item(&d, "ptr")?,
                    idx: item(&d, "idx")?,
                    vals: item::<Vec<f64>>(&d, "vals")?,
                }
                .checked()
                .map_err(value_error)?,
            ),
            None => None,
        };
        let out = self
            .map
            .compose(given.as_ref(), rows)
            .map_err(value_error)?;
        let d = PyDict::new(py);
        d.set_item("rows", out.rows)?;
        d.set_item("cols", out.cols)?;
        d.set_item("ptr", out.ptr)?;
        d.set_item("idx", out.idx)?;
        d.set_item("vals", PyArray1::from_vec(py, out.vals))?;
        Ok(d)
    }

    fn __repr__(&self) -> String {
        format!("CoordinateMap({}, n={})", self.map.kind(), self.map.dim())
    }

    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let (how, arg) = &self.made_by;
        let make = py.get_type::<CoordinateMap>().getattr(*how)?;
        let arg = arg.bind(py).clone();
        let args = if *how == "fourier" {
            arg
        } else {
            (arg,).into_pyobject(py)?.into_any()
        };
        Ok((make, args))
    }
}

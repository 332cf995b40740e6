//! `_core.FourierGrid`: the real Fourier coordinates of a periodic grid (the wave equation's
//! coordinate map), planned once and used by the Python layer for states on the way in and out.

use std::borrow::Cow;
use std::sync::{Arc, Mutex};

use numpy::{
    PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use trigint_core::spectral::{Part, Spectral, SpectralWorkspace};

use crate::potential::to_2d;

/// FourierGrid(shape, order=None): u = S q and q = Sᵀu / N between grid values (row-major, N
/// per row) and real Fourier coordinates (in the order of `wavevectors()`, or in `order`: the
/// coordinate k of q is the grid's coordinate order[k]; checked once, here).
#[pyclass(frozen, module = "trigint._core")]
pub struct FourierGrid {
    pub(crate) grid: Arc<Spectral>,
    order: Option<Arc<Vec<usize>>>,
    /// A workspace kept for the next call (a call takes it; calls that overlap make their own).
    kept: Mutex<Option<SpectralWorkspace>>,
}

impl FourierGrid {
    /// The rows of `x` (borrowed when contiguous), after checking their length.
    fn rows<'a>(
        &self,
        x: &'a PyReadonlyArray2<f64>,
        what: &str,
    ) -> PyResult<(usize, Cow<'a, [f64]>)> {
        let n = self.grid.points();
        if x.shape()[1] != n {
            return Err(PyValueError::new_err(format!(
                "{what}: expected rows of {n} values, got {}",
                x.shape()[1]
            )));
        }
        // (`as_slice` also takes a column-major array, in its memory order: rows are wanted)
        let data = match x.as_slice() {
            Ok(s) if x.is_c_contiguous() => Cow::Borrowed(s),
            _ => Cow::Owned(x.as_array().iter().copied().collect()),
        };
        Ok((x.shape()[0], data))
    }

    /// The order of a call: `order` checked, or the grid's own.
    fn order(
        &self,
        order: Option<PyReadonlyArray1<i64>>,
        what: &str,
    ) -> PyResult<Option<Arc<Vec<usize>>>> {
        match order {
            Some(order) => Ok(Some(Arc::new(checked_order(&self.grid, &order, what)?))),
            None => Ok(self.order.clone()),
        }
    }

    fn workspace(&self) -> SpectralWorkspace {
        let kept = self.kept.lock().ok().and_then(|mut k| k.take());
        kept.unwrap_or_else(|| self.grid.workspace())
    }

    fn keep(&self, ws: SpectralWorkspace) {
        if let Ok(mut k) = self.kept.lock() {
            *k = Some(ws);
        }
    }
}

#[pymethods]
impl FourierGrid {
    #[new]
    #[pyo3(signature = (shape, order=None))]
    fn new(shape: Vec<usize>, order: Option<PyReadonlyArray1<i64>>) -> PyResult<Self> {
        let grid = Spectral::shared(&shape).map_err(|e| PyValueError::new_err(e.to_string()))?;
        let order = match order {
            Some(o) => Some(Arc::new(checked_order(&grid, &o, "FourierGrid")?)),
            None => None,
        };
        Ok(FourierGrid {
            grid,
            order,
            kept: Mutex::new(None),
        })
    }

    /// ordered(order) -> this grid (its plans shared) with its coordinates in `order`, checked
    /// once, so that `to_grid` and `from_grid` need no `order` per call.
    fn ordered(&self, order: PyReadonlyArray1<i64>) -> PyResult<FourierGrid> {
        Ok(FourierGrid {
            grid: Arc::clone(&self.grid),
            order: Some(Arc::new(checked_order(&self.grid, &order, "ordered")?)),
            kept: Mutex::new(None),
        })
    }

    #[getter]
    fn shape(&self) -> Vec<usize> {
        self.grid.shape().to_vec()
    }

    /// The wavevector of each coordinate, shape (N, d).
    fn wavevectors<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<i64>>> {
        let d = self.grid.shape().len();
        PyArray1::from_slice(py, self.grid.wavevectors()).reshape([self.grid.points(), d])
    }

    /// Each coordinate's part of its mode: 0 a self-conjugate mode's real coefficient, 1 the
    /// cosine (a) and 2 the sine (b) coordinate of a conjugate pair.
    fn parts<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<u8>> {
        let parts: Vec<u8> = self
            .grid
            .slots()
            .iter()
            .map(|s| match s.part {
                Part::Real => 0,
                Part::Cos => 1,
                Part::Sin => 2,
            })
            .collect();
        PyArray1::from_vec(py, parts)
    }

    /// to_grid(q, order=None) -> u = S q, row by row; with `order`, coordinate k of a row of q
    /// is the grid's coordinate order[k].
    #[pyo3(signature = (q, order=None))]
    fn to_grid<'py>(
        &self,
        py: Python<'py>,
        q: PyReadonlyArray2<f64>,
        order: Option<PyReadonlyArray1<i64>>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let (m, data) = self.rows(&q, "to_grid")?;
        let order = self.order(order, "to_grid")?;
        let n = self.grid.points();
        let mut out = vec![0.0; m * n];
        let mut ws = self.workspace();
        py.detach(|| {
            self.grid
                .rows_to_grid(order.as_ref().map(|o| &o[..]), &data, &mut out, &mut ws)
        });
        self.keep(ws);
        to_2d(py, out, m, n)
    }

    /// from_grid(u, order=None) -> q = Sᵀu / N (the inverse of `to_grid`), row by row; with
    /// `order`, coordinate k of a row of q is the grid's coordinate order[k].
    #[pyo3(name = "from_grid", signature = (u, order=None))]
    fn fourier_of<'py>(
        &self,
        py: Python<'py>,
        u: PyReadonlyArray2<f64>,
        order: Option<PyReadonlyArray1<i64>>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let (m, data) = self.rows(&u, "from_grid")?;
        let order = self.order(order, "from_grid")?;
        let n = self.grid.points();
        let mut out = vec![0.0; m * n];
        let mut ws = self.workspace();
        py.detach(|| {
            self.grid
                .rows_from_grid(order.as_ref().map(|o| &o[..]), &data, &mut out, &mut ws)
        });
        self.keep(ws);
        to_2d(py, out, m, n)
    }

    #[allow(clippy::type_complexity)]
    fn __reduce__<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<(
        Bound<'py, PyAny>,
        (Vec<usize>, Option<Bound<'py, PyArray1<i64>>>),
    )> {
        let order = self.order.as_ref().map(|o| {
            let o: Vec<i64> = o.iter().map(|&k| k as i64).collect();
            PyArray1::from_vec(py, o)
        });
        Ok((
            py.get_type::<FourierGrid>().into_any(),
            (self.shape(), order),
        ))
    }
}

/// `order` as indices, checked to be a permutation of the grid's coordinates.
fn checked_order(
    grid: &Spectral,
    order: &PyReadonlyArray1<i64>,
    what: &str,
) -> PyResult<Vec<usize>> {
    let n = grid.points();
    let mut seen = vec![false; n];
    let mut out = Vec::with_capacity(n);
    for &k in order.as_array().iter() {
        let fits = usize::try_from(k).ok().filter(|&k| k < n && !seen[k]);
        let Some(k) = fits else {
            return Err(PyValueError::new_err(format!(
                "{what}: order must be a permutation of 0..{n}; {k} is out of range or repeated"
            )));
        };
        seen[k] = true;
        out.push(k);
    }
    if out.len() != n {
        return Err(PyValueError::new_err(format!(
            "{what}: order has {} entries for {n} coordinates",
            out.len()
        )));
    }
    Ok(out)
}

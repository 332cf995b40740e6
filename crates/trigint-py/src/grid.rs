//! `_core.FourierGrid`: the real Fourier coordinates of a periodic grid (the wave equation's
//! coordinate map), planned once and used by the Python layer for states on the way in and out.

use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use trigint_core::spectral::{Part, Spectral};

use crate::potential::to_2d;

/// FourierGrid(shape): u = S q and q = Sᵀu / N between grid values (row-major, N per row) and
/// real Fourier coordinates (in the order of `wavevectors()`).
#[pyclass(frozen, module = "trigint._core")]
pub struct FourierGrid {
    grid: Spectral,
}

impl FourierGrid {
    fn rows(&self, x: &PyReadonlyArray2<f64>, what: &str) -> PyResult<(usize, Vec<f64>)> {
        let n = self.grid.points();
        if x.shape()[1] != n {
            return Err(PyValueError::new_err(format!(
                "{what}: expected rows of {n} values, got {}",
                x.shape()[1]
            )));
        }
        Ok((x.shape()[0], x.as_array().iter().copied().collect()))
    }
}

#[pymethods]
impl FourierGrid {
    #[new]
    fn new(shape: Vec<usize>) -> PyResult<Self> {
        let grid = Spectral::new(&shape).map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(FourierGrid { grid })
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

    /// to_grid(q) -> u = S q, row by row.
    fn to_grid<'py>(
        &self,
        py: Python<'py>,
        q: PyReadonlyArray2<f64>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let (m, data) = self.rows(&q, "to_grid")?;
        let n = self.grid.points();
        let mut out = vec![0.0; m * n];
        py.detach(|| {
            let mut ws = self.grid.workspace();
            for (q, u) in data.chunks_exact(n).zip(out.chunks_exact_mut(n)) {
                self.grid.to_grid(q, u, &mut ws);
            }
        });
        to_2d(py, out, m, n)
    }

    /// from_grid(u) -> q = Sᵀu / N (the inverse of `to_grid`), row by row.
    #[pyo3(name = "from_grid")]
    fn fourier_of<'py>(
        &self,
        py: Python<'py>,
        u: PyReadonlyArray2<f64>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let (m, mut data) = self.rows(&u, "from_grid")?;
        let n = self.grid.points();
        let mut out = vec![0.0; m * n];
        py.detach(|| {
            let mut ws = self.grid.workspace();
            for (u, q) in data.chunks_exact_mut(n).zip(out.chunks_exact_mut(n)) {
                self.grid.transpose(u, q, 1.0 / n as f64, &mut ws);
            }
        });
        to_2d(py, out, m, n)
    }

    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, (Vec<usize>,))> {
        Ok((py.get_type::<FourierGrid>().into_any(), (self.shape(),)))
    }
}

//! The one map between a problem's coordinates as its user writes them and the core's own:
//! slow coordinates first, then each oscillatory block contiguous (see `docs/design.md`).
//!
//! * **Identity**: the user's order already is the core's.
//! * **Permuted** (a diagonal Ω): core coordinate k is user coordinate `perm[k]`.
//! * **Modal** (a stiffness matrix A = QΛQᵀ): q = Q x, the core steps x = Qᵀq.
//! * **Fourier** (a wave equation): grid values u = S q, q = Sᵀu / N, with core coordinate k the
//!   grid's real Fourier coordinate `order[k]` ([`Spectral`]).
//!
//! States go in through [`CoordinateMap::to_core`] and come back through
//! [`CoordinateMap::to_user`], row by row, in a fixed order of operations: a state has the same
//! bits alone and in a batch. A potential that reads the user's coordinates through a linear
//! map M reads the core's through M∘(to_user) ([`CoordinateMap::compose`]); the permutation and
//! the modal basis are orthogonal, so a force goes back with `to_core`.

use std::sync::{Arc, Mutex};

use crate::basis::rows_times;
use crate::error::{CoreError, CoreResult};
use crate::spectral::{Spectral, SpectralWorkspace};

/// A linear map in compressed-row form (`rows` × `cols`): row r has the entries
/// `vals[ptr[r]..ptr[r + 1]]` in the columns `idx[ptr[r]..ptr[r + 1]]`, summed in that order.
#[derive(Debug, Clone, PartialEq)]
pub struct SparseMap {
    pub rows: usize,
    pub cols: usize,
    pub ptr: Vec<usize>,
    pub idx: Vec<usize>,
    pub vals: Vec<f64>,
}

impl SparseMap {
    /// Checks the arrays' lengths and ranges.
    pub fn checked(self) -> CoreResult<Self> {
        let bad = |why: String| Err(CoreError::invalid("map", why));
        if self.ptr.len() != self.rows + 1 || self.ptr.first() != Some(&0) {
            return bad(format!(
                "ptr must have rows + 1 = {} entries starting at 0",
                self.rows + 1
            ));
        }
        if self.ptr.windows(2).any(|w| w[0] > w[1]) || self.ptr[self.rows] != self.idx.len() {
            return bad("ptr must be non-decreasing and end at the number of entries".into());
        }
        if self.idx.len() != self.vals.len() {
            return bad(format!(
                "{} column indices for {} values",
                self.idx.len(),
                self.vals.len()
            ));
        }
        if let Some(&j) = self.idx.iter().find(|&&j| j >= self.cols) {
            return bad(format!("column {j} out of range for {} columns", self.cols));
        }
        Ok(self)
    }
}

/// How the core's coordinates are made from the user's.
pub enum CoordinateMap {
    Identity {
        n: usize,
    },
    Permuted {
        /// core coordinate k is user coordinate `perm[k]`
        perm: Vec<usize>,
        /// user coordinate i is core coordinate `inverse[i]`
        inverse: Vec<usize>,
    },
    Modal {
        n: usize,
        /// Q, row-major: q = Q x
        basis: Vec<f64>,
    },
    Fourier {
        grid: Arc<Spectral>,
        /// core coordinate k is the grid's coordinate `order[k]`
        order: Vec<usize>,
        /// `order` is the identity (a 1-D grid's frequencies are in the grid's order): the
        /// transforms read and write the rows in place of a permutation pass, which cost 40%
        /// of a transform on 2¹⁶ points
        in_grid_order: bool,
        /// a workspace kept for the next call (calls that overlap make their own)
        kept: Mutex<Option<SpectralWorkspace>>,
    },
}

impl std::fmt::Debug for CoordinateMap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "CoordinateMap({}, n = {})", self.kind(), self.dim())
    }
}

/// `order` checked to be a permutation of 0..n.
fn checked_permutation(order: Vec<usize>, n: usize, what: &'static str) -> CoreResult<Vec<usize>> {
    let mut seen = vec![false; n];
    for &k in &order {
        if k >= n || std::mem::replace(&mut seen[k], true) {
            return Err(CoreError::invalid(
                what,
                format!("must be a permutation of 0..{n}; {k} is out of range or repeated"),
            ));
        }
    }
    if order.len() != n {
        return Err(CoreError::invalid(
            what,
            format!("has {} entries for {n} coordinates", order.len()),
        ));
    }
    Ok(order)
}

impl CoordinateMap {
    /// The map of `perm` (core coordinate k is user coordinate `perm[k]`): the identity when it
    /// is one.
    pub fn permuted(perm: Vec<usize>) -> CoreResult<Self> {
        let n = perm.len();
        let perm = checked_permutation(perm, n, "perm")?;
        if perm.iter().enumerate().all(|(k, &i)| k == i) {
            return Ok(CoordinateMap::Identity { n });
        }
        let mut inverse = vec![0; n];
        for (k, &i) in perm.iter().enumerate() {
            inverse[i] = k;
        }
        Ok(CoordinateMap::Permuted { perm, inverse })
    }

    /// The modal map of the orthogonal n × n basis Q (row-major): q = Q x.
    pub fn modal(n: usize, basis: Vec<f64>) -> CoreResult<Self> {
        if basis.len() != n * n {
            return Err(CoreError::invalid(
                "basis",
                format!(
                    "expected {n} x {n} = {} entries, got {}",
                    n * n,
                    basis.len()
                ),
            ));
        }
        if let Some(i) = basis.iter().position(|x| !x.is_finite()) {
            return Err(CoreError::invalid(
                "basis",
                format!("entry {i} is not finite"),
            ));
        }
        Ok(CoordinateMap::Modal { n, basis })
    }

    /// The Fourier map of `grid` with its coordinates in `order`.
    pub fn fourier(grid: Arc<Spectral>, order: Vec<usize>) -> CoreResult<Self> {
        let order = checked_permutation(order, grid.points(), "order")?;
        Ok(CoordinateMap::Fourier {
            grid,
            in_grid_order: order.iter().enumerate().all(|(k, &i)| k == i),
            order,
            kept: Mutex::new(None),
        })
    }

    /// Coordinates per state.
    pub fn dim(&self) -> usize {
        match self {
            CoordinateMap::Identity { n } | CoordinateMap::Modal { n, .. } => *n,
            CoordinateMap::Permuted { perm, .. } => perm.len(),
            CoordinateMap::Fourier { order, .. } => order.len(),
        }
    }

    /// "identity", "permuted", "modal" or "fourier".
    pub fn kind(&self) -> &'static str {
        match self {
            CoordinateMap::Identity { .. } => "identity",
            CoordinateMap::Permuted { .. } => "permuted",
            CoordinateMap::Modal { .. } => "modal",
            CoordinateMap::Fourier { .. } => "fourier",
        }
    }

    pub fn is_identity(&self) -> bool {
        matches!(self, CoordinateMap::Identity { .. })
    }

    fn check_rows(&self, x: &[f64], out: &[f64]) {
        let n = self.dim().max(1);
        assert!(
            x.len() == out.len() && x.len().is_multiple_of(n),
            "rows of {n} expected"
        );
    }

    /// Rows of user coordinates → rows of core coordinates (`out` overwritten).
    pub fn to_core(&self, x: &[f64], out: &mut [f64]) {
        self.check_rows(x, out);
        match self {
            CoordinateMap::Identity { .. } => out.copy_from_slice(x),
            CoordinateMap::Permuted { perm, .. } => gather(x, out, perm),
            CoordinateMap::Modal { n, basis, .. } => rows_times(x, basis, *n, *n, out),
            CoordinateMap::Fourier { .. } => self.through_grid(x, out, Spectral::rows_from_grid),
        }
    }

    /// Rows of core coordinates → rows of user coordinates (`out` overwritten).
    pub fn to_user(&self, x: &[f64], out: &mut [f64]) {
        self.check_rows(x, out);
        match self {
            CoordinateMap::Identity { .. } => out.copy_from_slice(x),
            CoordinateMap::Permuted { inverse, .. } => gather(x, out, inverse),
            CoordinateMap::Modal { n, basis } => rows_times_transposed(x, basis, *n, out),
            CoordinateMap::Fourier { .. } => self.through_grid(x, out, Spectral::rows_to_grid),
        }
    }

    /// A Fourier map's `transform` of the rows, with the kept workspace and the map's order
    /// (none where it is the grid's own).
    fn through_grid(&self, x: &[f64], out: &mut [f64], transform: RowsTransform) {
        if let CoordinateMap::Fourier {
            grid,
            order,
            in_grid_order,
            kept,
        } = self
        {
            let mut ws = take(kept, grid);
            transform(grid, (!in_grid_order).then_some(order), x, out, &mut ws);
            keep(kept, ws);
        }
    }

    /// Rows of per-coordinate numbers given in the order of the problem's frequencies (a
    /// method's coefficients) in the core's order: only a permutation moves them, since a
    /// modal or Fourier problem's frequencies are listed in its core coordinates already.
    pub fn numbers_to_core(&self, x: &[f64], out: &mut [f64]) {
        match self {
            CoordinateMap::Permuted { .. } => self.to_core(x, out),
            _ => {
                self.check_rows(x, out);
                out.copy_from_slice(x)
            }
        }
    }

    /// The map M of a potential's inputs (`rows` of them, read from the user's coordinates;
    /// None: the first `rows` coordinates themselves) as a map of the core's coordinates,
    /// M∘(to_user).
    ///
    /// A permutation renames M's columns (its entries and their order kept: the same sums).
    /// The modal map is the product M Q, each entry summed over M's entries in their order;
    /// entries at or below 1e-15 of their row's largest are the product's rounding noise (exact
    /// zeros of a sparse Q combined with ±1/√2) and are dropped. A Fourier problem's potentials
    /// are written in its Fourier coordinates: there is nothing to compose.
    pub fn compose(&self, m: Option<&SparseMap>, rows: usize) -> CoreResult<SparseMap> {
        let n = self.dim();
        if let Some(m) = m {
            if m.cols != n {
                return Err(CoreError::invalid(
                    "map",
                    format!("reads {} coordinates, the problem has {n}", m.cols),
                ));
            }
        }
        let given = || -> SparseMap {
            m.cloned().unwrap_or_else(|| {
                let rows_n = rows.min(n);
                SparseMap {
                    rows,
                    cols: n,
                    ptr: (0..=rows).map(|r| r.min(rows_n)).collect(),
                    idx: (0..rows_n).collect(),
                    vals: vec![1.0; rows_n],
                }
            })
        };
        match self {
            CoordinateMap::Identity { .. } => Ok(given()),
            CoordinateMap::Permuted { inverse, .. } => {
                let mut out = given();
                for j in &mut out.idx {
                    *j = inverse[*j];
                }
                Ok(out)
            }
            CoordinateMap::Modal { basis, .. } => Ok(modal_product(&given(), basis, n)),
            CoordinateMap::Fourier { .. } => Err(CoreError::invalid(
                "map",
                "a wave problem's potentials read its Fourier coordinates directly; there is no \
                 map of grid values to compose",
            )),
        }
    }
}

/// y = x Qᵀ for rows x, read from Q itself: y_j = Σ_k x_k Q_jk summed over k in increasing order
/// from 0, the order of `rows_times(x, Qᵀ)` (the same bits, without a transposed copy of Q).
fn rows_times_transposed(x: &[f64], basis: &[f64], n: usize, out: &mut [f64]) {
    for (xr, yr) in x.chunks_exact(n.max(1)).zip(out.chunks_exact_mut(n.max(1))) {
        for (y, qr) in yr.iter_mut().zip(basis.chunks_exact(n)) {
            let mut acc = 0.0;
            for (a, q) in xr.iter().zip(qr) {
                acc += a * q;
            }
            *y = acc;
        }
    }
}

/// out[k] = x[from[k]] in every row.
fn gather(x: &[f64], out: &mut [f64], from: &[usize]) {
    let n = from.len().max(1);
    for (xr, yr) in x.chunks_exact(n).zip(out.chunks_exact_mut(n)) {
        for (y, &i) in yr.iter_mut().zip(from) {
            *y = xr[i];
        }
    }
}

/// A transform of rows between grid values and Fourier coordinates
/// ([`Spectral::rows_to_grid`], [`Spectral::rows_from_grid`]).
type RowsTransform = fn(&Spectral, Option<&[usize]>, &[f64], &mut [f64], &mut SpectralWorkspace);

fn take(kept: &Mutex<Option<SpectralWorkspace>>, grid: &Spectral) -> SpectralWorkspace {
    let ws = kept.lock().ok().and_then(|mut k| k.take());
    ws.unwrap_or_else(|| grid.workspace())
}

fn keep(kept: &Mutex<Option<SpectralWorkspace>>, ws: SpectralWorkspace) {
    if let Ok(mut k) = kept.lock() {
        *k = Some(ws);
    }
}

/// M Q for sparse M and dense Q (n × n, row-major), with the rounding noise dropped.
fn modal_product(m: &SparseMap, basis: &[f64], n: usize) -> SparseMap {
    let mut out = SparseMap {
        rows: m.rows,
        cols: n,
        ptr: vec![0],
        idx: Vec::new(),
        vals: Vec::new(),
    };
    let mut row = vec![0.0; n];
    for r in 0..m.rows {
        row.fill(0.0);
        for e in m.ptr[r]..m.ptr[r + 1] {
            let (a, q) = (m.vals[e], &basis[m.idx[e] * n..(m.idx[e] + 1) * n]);
            for (y, &x) in row.iter_mut().zip(q) {
                *y += a * x;
            }
        }
        // (as NumPy's max: a NaN makes the row's largest NaN, and then nothing is dropped)
        let big = row.iter().fold(0.0f64, |b, y| {
            if y.is_nan() || b.is_nan() {
                f64::NAN
            } else {
                b.max(y.abs())
            }
        });
        for (j, &y) in row.iter().enumerate() {
            if y != 0.0 && (big.is_nan() || y.abs() > 1e-15 * big) {
                out.idx.push(j);
                out.vals.push(y);
            }
        }
        out.ptr.push(out.idx.len());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rotation(n: usize) -> Vec<f64> {
        // a Givens rotation of coordinates 0 and 1, the identity elsewhere
        let (c, s) = (0.6, 0.8);
        let mut q = vec![0.0; n * n];
        for i in 0..n {
            q[i * n + i] = 1.0;
        }
        q[0] = c;
        q[1] = -s;
        q[n] = s;
        q[n + 1] = c;
        q
    }

    #[test]
    fn a_permutation_round_trips_and_renames_columns() {
        let map = CoordinateMap::permuted(vec![2, 0, 1]).unwrap();
        let x = [10.0, 11.0, 12.0, 20.0, 21.0, 22.0];
        let mut core = [0.0; 6];
        map.to_core(&x, &mut core);
        assert_eq!(core, [12.0, 10.0, 11.0, 22.0, 20.0, 21.0]);
        let mut back = [0.0; 6];
        map.to_user(&core, &mut back);
        assert_eq!(back, x);
        // y = x_user[2] − x_user[0] reads core coordinates 0 and 1
        let m = SparseMap {
            rows: 1,
            cols: 3,
            ptr: vec![0, 2],
            idx: vec![2, 0],
            vals: vec![1.0, -1.0],
        };
        assert_eq!(map.compose(Some(&m), 1).unwrap().idx, vec![0, 1]);
        assert!(CoordinateMap::permuted(vec![0, 1, 2])
            .unwrap()
            .is_identity());
        assert!(CoordinateMap::permuted(vec![0, 0, 2]).is_err());
    }

    #[test]
    fn the_modal_map_round_trips_and_composes_with_the_basis() {
        let n = 3;
        let map = CoordinateMap::modal(n, rotation(n)).unwrap();
        let q = [1.0, 2.0, 3.0];
        let mut x = [0.0; 3];
        map.to_core(&q, &mut x);
        let mut back = [0.0; 3];
        map.to_user(&x, &mut back);
        for (a, b) in back.iter().zip(q) {
            assert!((a - b).abs() < 1e-15);
        }
        // None: the identity on the first two coordinates, M Q = Q's first two rows
        let c = map.compose(None, 2).unwrap();
        assert_eq!(
            (c.ptr.clone(), c.idx.clone()),
            (vec![0, 2, 4], vec![0, 1, 0, 1])
        );
        assert_eq!(c.vals, vec![0.6, -0.8, 0.8, 0.6]);
        // reading M∘Q of core coordinates gives M of the user's
        let mq: f64 = c.idx[..2]
            .iter()
            .zip(&c.vals[..2])
            .map(|(&j, v)| v * x[j])
            .sum();
        assert!((mq - q[0]).abs() < 1e-15);
    }

    #[test]
    fn to_user_has_the_bits_of_the_product_with_the_transposed_basis() {
        let n = 5;
        let q: Vec<f64> = (0..n * n).map(|i| (i as f64 * 0.77).sin()).collect();
        let mut t = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                t[j * n + i] = q[i * n + j];
            }
        }
        let x: Vec<f64> = (0..3 * n).map(|i| (i as f64 * 1.3).cos() * 1e3).collect();
        let (mut want, mut got) = (vec![0.0; 3 * n], vec![0.0; 3 * n]);
        rows_times(&x, &t, n, n, &mut want);
        CoordinateMap::modal(n, q).unwrap().to_user(&x, &mut got);
        assert_eq!(got, want);
    }

    #[test]
    fn a_row_with_a_nan_keeps_its_entries_as_numpy_does() {
        let m = SparseMap {
            rows: 1,
            cols: 2,
            ptr: vec![0, 2],
            idx: vec![0, 1],
            vals: vec![f64::NAN, 1e-20],
        };
        let c = CoordinateMap::modal(2, vec![1.0, 0.0, 0.0, 1.0])
            .unwrap()
            .compose(Some(&m), 1)
            .unwrap();
        assert_eq!(c.idx, vec![0, 1]);
    }

    #[test]
    fn the_fourier_map_round_trips() {
        let grid = Arc::new(Spectral::new(&[8]).unwrap());
        let order: Vec<usize> = (0..8).rev().collect();
        let map = CoordinateMap::fourier(grid, order).unwrap();
        let u: Vec<f64> = (0..16).map(|i| (i as f64 * 0.7).sin()).collect();
        let mut q = vec![0.0; 16];
        map.to_core(&u, &mut q);
        let mut back = vec![0.0; 16];
        map.to_user(&q, &mut back);
        for (a, b) in back.iter().zip(&u) {
            assert!((a - b).abs() < 1e-14);
        }
        assert!(map.compose(None, 8).is_err());
    }
}

//! Sparse linear maps y = L x in a form that vectorizes: strided diagonal segments.
//!
//! A chain's springs are linear forms of neighbouring coordinates, so the k-th entry of
//! consecutive rows usually sits in consecutive (or equally spaced) columns with the same
//! coefficient. A [`Segment`] is such a run: rows r₀ … r₀+len−1, columns c₀, c₀+s, c₀+2s, …,
//! and one coefficient (±1, a number, or one per row). y = Lx and f += Lᵀv are then a few loops
//! over contiguous memory instead of one gather per entry. The segments are applied in a fixed
//! order (entry 0 of every row first, then entry 1, …), so the sums are deterministic.
//! Rows whose coefficients all differ become segments of one row: correct, only slower.

use crate::error::{CoreError, CoreResult};
use crate::real::Real;

/// The coefficient of a segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SegmentCoef {
    Plus,
    Minus,
    Scalar(f64),
}

/// Rows `row .. row + len` take column `col + k * stride` (k = 0 … len − 1) times the coefficient.
#[derive(Debug, Clone, PartialEq)]
pub struct Segment {
    pub row: usize,
    pub len: usize,
    pub col: usize,
    pub stride: isize,
    pub coef: SegmentCoef,
}

impl Segment {
    #[inline(always)]
    fn column(&self, k: usize) -> usize {
        (self.col as isize + k as isize * self.stride) as usize
    }
}

/// A sparse matrix (rows × cols) as strided segments.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearMap {
    pub rows: usize,
    pub cols: usize,
    pub segments: Vec<Segment>,
}

impl LinearMap {
    /// From compressed sparse rows: row r holds `cols[ptr[r]..ptr[r+1]]`, `vals[…]`.
    /// Entries of a row are taken in increasing column order; zeros are dropped.
    pub fn from_csr(
        rows: usize,
        cols: usize,
        ptr: &[usize],
        col_idx: &[usize],
        vals: &[f64],
    ) -> CoreResult<Self> {
        let bad = |reason: String| Err(CoreError::invalid("linear map", reason));
        if ptr.len() != rows + 1 || ptr[0] != 0 {
            return bad(format!(
                "row pointer of length {} for {rows} rows",
                ptr.len()
            ));
        }
        if ptr.windows(2).any(|w| w[1] < w[0]) || ptr[rows] != col_idx.len() {
            return bad("row pointers must increase to the number of entries".into());
        }
        if col_idx.len() != vals.len() {
            return bad("as many values as column indices are needed".into());
        }
        if let Some(&c) = col_idx.iter().find(|&&c| c >= cols) {
            return bad(format!("column {c} out of range for {cols} columns"));
        }
        if let Some(v) = vals.iter().find(|v| !v.is_finite()) {
            return bad(format!("entries must be finite, got {v}"));
        }
        // Entry k of each row, sorted by column.
        let mut entries: Vec<Vec<(usize, f64)>> = (0..rows)
            .map(|r| {
                let mut e: Vec<(usize, f64)> = (ptr[r]..ptr[r + 1])
                    .map(|t| (col_idx[t], vals[t]))
                    .filter(|&(_, v)| v != 0.0)
                    .collect();
                e.sort_by_key(|&(c, _)| c);
                e
            })
            .collect();
        for (r, e) in entries.iter_mut().enumerate() {
            if e.windows(2).any(|w| w[0].0 == w[1].0) {
                return bad(format!("row {r} lists a column twice"));
            }
        }
        let width = entries.iter().map(Vec::len).max().unwrap_or(0);
        let mut segments = Vec::new();
        for k in 0..width {
            let mut r = 0;
            while r < rows {
                let Some(&(c0, v0)) = entries[r].get(k) else {
                    r += 1;
                    continue;
                };
                // Extend the run while entry k exists with the same coefficient and the
                // column step stays.
                let mut len = 1;
                let mut stride = 0isize;
                while r + len < rows {
                    let Some(&(c, v)) = entries[r + len].get(k) else {
                        break;
                    };
                    if v != v0 {
                        break;
                    }
                    let step = c as isize - entries[r + len - 1][k].0 as isize;
                    if len == 1 {
                        stride = step;
                    } else if step != stride {
                        break;
                    }
                    len += 1;
                }
                let coef = match v0 {
                    1.0 => SegmentCoef::Plus,
                    -1.0 => SegmentCoef::Minus,
                    c => SegmentCoef::Scalar(c),
                };
                segments.push(Segment {
                    row: r,
                    len,
                    col: c0,
                    stride,
                    coef,
                });
                r += len;
            }
        }
        Ok(LinearMap {
            rows,
            cols,
            segments,
        })
    }

    /// The entries row by row, in application order: (row, column, coefficient).
    pub fn entries(&self) -> Vec<(usize, usize, f64)> {
        let mut out = Vec::new();
        for s in &self.segments {
            for k in 0..s.len {
                let v = match s.coef {
                    SegmentCoef::Plus => 1.0,
                    SegmentCoef::Minus => -1.0,
                    SegmentCoef::Scalar(c) => c,
                };
                out.push((s.row + k, s.column(k), v));
            }
        }
        out
    }

    /// y = L x (y is overwritten).
    #[inline(always)]
    pub fn apply<L: Real>(&self, x: &[L], y: &mut [L]) {
        y[..self.rows].fill(L::zero());
        for s in &self.segments {
            let y = &mut y[s.row..s.row + s.len];
            if s.stride == 1 {
                let x = &x[s.col..s.col + s.len];
                match s.coef {
                    SegmentCoef::Plus => (0..s.len).for_each(|k| y[k] += x[k]),
                    SegmentCoef::Minus => (0..s.len).for_each(|k| y[k] -= x[k]),
                    SegmentCoef::Scalar(c) => {
                        let c = L::splat(c);
                        (0..s.len).for_each(|k| y[k] += c * x[k])
                    }
                }
            } else {
                for k in 0..s.len {
                    let xk = x[s.column(k)];
                    match s.coef {
                        SegmentCoef::Plus => y[k] += xk,
                        SegmentCoef::Minus => y[k] -= xk,
                        SegmentCoef::Scalar(c) => y[k] += L::splat(c) * xk,
                    }
                }
            }
        }
    }

    /// f += Lᵀ v.
    #[inline(always)]
    pub fn apply_transpose_add<L: Real>(&self, v: &[L], f: &mut [L]) {
        for s in &self.segments {
            let v = &v[s.row..s.row + s.len];
            if s.stride == 1 {
                let f = &mut f[s.col..s.col + s.len];
                match s.coef {
                    SegmentCoef::Plus => (0..s.len).for_each(|k| f[k] += v[k]),
                    SegmentCoef::Minus => (0..s.len).for_each(|k| f[k] -= v[k]),
                    SegmentCoef::Scalar(c) => {
                        let c = L::splat(c);
                        (0..s.len).for_each(|k| f[k] += c * v[k])
                    }
                }
            } else {
                for k in 0..s.len {
                    let c = s.column(k);
                    match s.coef {
                        SegmentCoef::Plus => f[c] += v[k],
                        SegmentCoef::Minus => f[c] -= v[k],
                        SegmentCoef::Scalar(a) => f[c] += L::splat(a) * v[k],
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::fixtures::fpu_springs;

    #[test]
    fn segments_reproduce_the_matrix_and_its_transpose() {
        let m = 5;
        let (ptr, cols, vals) = fpu_springs(m);
        let l = LinearMap::from_csr(m + 1, 2 * m, &ptr, &cols, &vals).unwrap();
        assert!(l.segments.len() <= 12, "{:?}", l.segments);
        let x: Vec<f64> = (0..2 * m).map(|i| (i as f64 * 1.3).sin()).collect();
        let mut y = vec![0.0; m + 1];
        l.apply(&x, &mut y);
        let dense = |r: usize, c: usize| -> f64 {
            (ptr[r]..ptr[r + 1])
                .filter(|&t| cols[t] == c)
                .map(|t| vals[t])
                .sum()
        };
        for (r, &yr) in y.iter().enumerate() {
            let want: f64 = (0..2 * m).map(|c| dense(r, c) * x[c]).sum();
            assert!((yr - want).abs() < 1e-15);
        }
        let v: Vec<f64> = (0..=m).map(|r| (r as f64 * 0.7).cos()).collect();
        let mut f = vec![0.0; 2 * m];
        l.apply_transpose_add(&v, &mut f);
        for (c, &fc) in f.iter().enumerate() {
            let want: f64 = (0..=m).map(|r| dense(r, c) * v[r]).sum();
            assert!((fc - want).abs() < 1e-15);
        }
        assert_eq!(l.entries().len(), cols.len());
    }

    #[test]
    fn bad_maps_are_refused() {
        assert!(LinearMap::from_csr(1, 2, &[0, 1], &[2], &[1.0]).is_err());
        assert!(LinearMap::from_csr(1, 2, &[0, 2], &[1, 1], &[1.0, 2.0]).is_err());
        assert!(LinearMap::from_csr(1, 2, &[0, 1], &[0], &[f64::NAN]).is_err());
        assert!(LinearMap::from_csr(2, 2, &[0, 1], &[0], &[1.0]).is_err());
    }
}

//! Sparse linear maps y = L x in a form that vectorizes: strided diagonal segments.
//!
//! A chain's springs are linear forms of neighbouring coordinates, so the k-th entry of
//! consecutive rows usually sits in consecutive (or equally spaced) columns with the same
//! coefficient. A [`Segment`] is such a run: rows r₀ … r₀+len−1, columns c₀, c₀+s, c₀+2s, …,
//! and one coefficient (±1, a number, or one per row). y = Lx and f += Lᵀv are then a few loops
//! over contiguous memory instead of one gather per entry. The segments are applied in a fixed
//! order (entry 0 of every row first, then entry 1, …), so the sums are deterministic.
//! Rows whose coefficients all differ become segments of one row: correct, only slower.
//!
//! When every segment runs along a diagonal (column step 1, or a single entry) and there are
//! few of them, both products run band by band instead: a band is a range of rows (or of
//! columns) that the same segments cross, and each of its entries is summed in registers over
//! those segments, in segment order, with one store. The additions are the segment passes'
//! own, in their order, so the bits are the same; the passes' loads and stores of the partial
//! sums are gone (FPU m = 1000: y = Lx took 5 passes over y, now one).

use crate::description::{FromDescription, Value};
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
    /// Row bands of y = Lx and column bands of f += Lᵀv, when the segments allow them.
    row_bands: Option<Vec<Band>>,
    col_bands: Option<Vec<Band>>,
}

/// Entries `start..end` of the output, each Σ_k c_k · input[entry + shift_k] (k in segment
/// order).
#[derive(Debug, Clone, PartialEq)]
struct Band {
    start: usize,
    end: usize,
    shift: Vec<isize>,
    coef: Vec<f64>,
}

/// More segments than this and the products stay segment passes (bands would cost
/// O(segments²) to build and have long inner sums).
const MAX_BANDED_SEGMENTS: usize = 64;

/// Bands need a segment's entries on one diagonal.
fn diagonal(s: &Segment) -> bool {
    s.stride == 1 || s.len == 1
}

impl Segment {
    /// The coefficient as a number.
    fn coef_value(&self) -> f64 {
        match self.coef {
            SegmentCoef::Plus => 1.0,
            SegmentCoef::Minus => -1.0,
            SegmentCoef::Scalar(c) => c,
        }
    }
}

/// The bands of an output of `size` entries where segment k covers `range(k)` and reads the
/// input at entry + `shift(k)`.
fn bands(
    segments: &[Segment],
    size: usize,
    range: impl Fn(&Segment) -> (usize, usize),
    shift: impl Fn(&Segment) -> isize,
) -> Vec<Band> {
    let mut cuts: Vec<usize> = segments
        .iter()
        .flat_map(|s| {
            let (a, b) = range(s);
            [a, b]
        })
        .chain([0, size])
        .collect();
    cuts.sort_unstable();
    cuts.dedup();
    cuts.windows(2)
        .map(|w| {
            let active: Vec<&Segment> = segments
                .iter()
                .filter(|s| {
                    let (a, b) = range(s);
                    a <= w[0] && w[1] <= b
                })
                .collect();
            Band {
                start: w[0],
                end: w[1],
                shift: active.iter().map(|s| shift(s)).collect(),
                coef: active.iter().map(|s| s.coef_value()).collect(),
            }
        })
        .collect()
}

/// out[j] = (from_zero ? 0 : out[j]) + Σ_k c_k src_k[j], the sum in k order, K known at compile
/// time so that the loop over j vectorizes.
#[inline(always)]
fn band_sum<L: Real, const K: usize>(out: &mut [L], from_zero: bool, src: [&[L]; K], c: &[f64]) {
    let c: [L; K] = std::array::from_fn(|k| L::splat(c[k]));
    let n = out.len();
    let src: [&[L]; K] = std::array::from_fn(|k| &src[k][..n]);
    for j in 0..n {
        let mut acc = if from_zero { L::zero() } else { out[j] };
        for k in 0..K {
            acc += c[k] * src[k][j];
        }
        out[j] = acc;
    }
}

/// One band: output entries start..end from the input at the band's shifts.
#[inline(always)]
fn run_band<L: Real>(band: &Band, input: &[L], out: &mut [L], from_zero: bool) {
    let len = band.end - band.start;
    let out = &mut out[band.start..band.end];
    let src = |k: usize| {
        let a = (band.start as isize + band.shift[k]) as usize;
        &input[a..a + len]
    };
    match band.shift.len() {
        0 => band_sum::<L, 0>(out, from_zero, [], &band.coef),
        1 => band_sum::<L, 1>(out, from_zero, [src(0)], &band.coef),
        2 => band_sum::<L, 2>(out, from_zero, [src(0), src(1)], &band.coef),
        3 => band_sum::<L, 3>(out, from_zero, [src(0), src(1), src(2)], &band.coef),
        4 => band_sum::<L, 4>(out, from_zero, [src(0), src(1), src(2), src(3)], &band.coef),
        k => {
            if from_zero {
                out.fill(L::zero());
            }
            for t in 0..k {
                let (x, c) = (src(t), L::splat(band.coef[t]));
                for (o, &x) in out.iter_mut().zip(x) {
                    *o += c * x;
                }
            }
        }
    }
}

impl FromDescription for LinearMap {
    /// `{"rows", "cols", "ptr", "idx", "vals"}`: compressed sparse rows (see [`from_csr`](Self::from_csr)).
    fn from_description(d: &Value) -> CoreResult<Self> {
        Self::from_csr(
            d.field("rows")?.to_usize("rows")?,
            d.field("cols")?.to_usize("cols")?,
            &d.field("ptr")?.to_usizes("ptr")?,
            &d.field("idx")?.to_usizes("idx")?,
            &d.field("vals")?.to_f64s("vals")?,
        )
    }
}

/// The optional field `"map"` of a description.
pub(crate) fn optional_map(d: &Value) -> CoreResult<Option<LinearMap>> {
    d.optional("map")
        .map(|m| LinearMap::from_description(m.to_dict("map")?))
        .transpose()
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
        let banded = segments.len() <= MAX_BANDED_SEGMENTS && segments.iter().all(diagonal);
        let (row_bands, col_bands) = if banded {
            (
                Some(bands(
                    &segments,
                    rows,
                    |s| (s.row, s.row + s.len),
                    |s| s.col as isize - s.row as isize,
                )),
                Some(bands(
                    &segments,
                    cols,
                    |s| (s.col, s.col + s.len),
                    |s| s.row as isize - s.col as isize,
                )),
            )
        } else {
            (None, None)
        };
        Ok(LinearMap {
            rows,
            cols,
            segments,
            row_bands,
            col_bands,
        })
    }

    /// The entries row by row, in application order: (row, column, coefficient).
    pub fn entries(&self) -> Vec<(usize, usize, f64)> {
        let mut out = Vec::new();
        for s in &self.segments {
            for k in 0..s.len {
                out.push((s.row + k, s.column(k), s.coef_value()));
            }
        }
        out
    }

    /// y = L x (y is overwritten).
    #[inline(always)]
    pub fn apply<L: Real>(&self, x: &[L], y: &mut [L]) {
        if let Some(bands) = &self.row_bands {
            // A plain loop: a closure would be outlined, out of the kernels' per-CPU copies.
            for b in bands {
                run_band(b, x, y, true);
            }
            return;
        }
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
        self.apply_transpose(v, f, true)
    }

    /// f = Lᵀ v (`add` false) or f += Lᵀ v, with the bits of zeroing f and adding.
    #[inline(always)]
    pub fn apply_transpose<L: Real>(&self, v: &[L], f: &mut [L], add: bool) {
        if let Some(bands) = &self.col_bands {
            for b in bands {
                run_band(b, v, f, !add);
            }
            return;
        }
        if !add {
            f[..self.cols].fill(L::zero());
        }
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
    fn bands_give_the_segment_passes_bits() {
        // The FPU's springs (4 diagonals of ±1), and a banded matrix of 6 diagonals with
        // numeric coefficients and ragged ends (more terms than the unrolled band sums).
        let (m, n) = (40, 37);
        let (p1, c1, v1) = fpu_springs(m);
        let (mut p2, mut c2, mut v2) = (vec![0], vec![], vec![]);
        for r in 0..n {
            for d in 0..6usize {
                if r + d < n + 2 && r + d >= 2 {
                    c2.push(r + d - 2);
                    v2.push(0.3 * d as f64 - 0.7);
                }
            }
            p2.push(c2.len());
        }
        let maps = [
            LinearMap::from_csr(m + 1, 2 * m, &p1, &c1, &v1).unwrap(),
            LinearMap::from_csr(n, n, &p2, &c2, &v2).unwrap(),
        ];
        for banded in maps {
            assert!(banded.row_bands.is_some() && banded.col_bands.is_some());
            let passes = LinearMap {
                row_bands: None,
                col_bands: None,
                ..banded.clone()
            };
            let x: Vec<f64> = (0..banded.cols)
                .map(|i| (i as f64 * 1.3).sin() * 1e3)
                .collect();
            let v: Vec<f64> = (0..banded.rows)
                .map(|r| (r as f64 * 0.7).cos() / 3.0)
                .collect();
            let (mut y1, mut y2) = (vec![7.0; banded.rows], vec![-7.0; banded.rows]);
            banded.apply(&x, &mut y1);
            passes.apply(&x, &mut y2);
            let (mut f1, mut f2) = (x.clone(), x.clone());
            banded.apply_transpose_add(&v, &mut f1);
            passes.apply_transpose_add(&v, &mut f2);
            let bits = |a: &[f64]| a.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&y1), bits(&y2));
            assert_eq!(bits(&f1), bits(&f2));
        }
    }

    #[test]
    fn bad_maps_are_refused() {
        assert!(LinearMap::from_csr(1, 2, &[0, 1], &[2], &[1.0]).is_err());
        assert!(LinearMap::from_csr(1, 2, &[0, 2], &[1, 1], &[1.0, 2.0]).is_err());
        assert!(LinearMap::from_csr(1, 2, &[0, 1], &[0], &[f64::NAN]).is_err());
        assert!(LinearMap::from_csr(2, 2, &[0, 1], &[0], &[1.0]).is_err());
    }
}

//! Real Fourier coordinates of a periodic grid: the coordinate map of the wave equation.
//!
//! A real field u on the grid x_k = 2πk/n (per axis, n even, d = 1, 2, 3 axes, N points in
//! all) has normalized Fourier coefficients û_j = FFT(u)_j / N with û_{−j} = conj(û_j). Its
//! real coordinates q, N of them, are
//!
//! * for a self-conjugate wavevector (j ≡ −j, every component 0 or n/2): q = û_j, real;
//! * for a pair {j, −j}: (a, b) with û_j = (a − i b)/√2 for the pair's representative j.
//!
//! Then mean_x u² = |q|² and u = S q with SᵀS = N·I: the grid is an orthogonal change of
//! coordinates up to the factor √N, and q'' + Ω²q = −∇U(q) with Ω = diag(ω_j) is the
//! spectral semi-discretization of u_tt = Δu − ρu − V'(u) for U(q) = mean_x V(u)
//! (Cohen, Hairer, Lubich, Numer. Math. 110 (2008), §2).
//!
//! The two transforms: u = S q is an inverse complex FFT along the first d − 1 axes of the
//! half spectrum and a complex-to-real FFT along the last; Sᵀw is the forward pair
//! (real-to-complex along the last axis, then complex), read at the representatives:
//! (Sᵀw)_a = √2 Re W_j, (Sᵀw)_b = −√2 Im W_j, (Sᵀw)_q = Re W_j for a self-conjugate j.

use std::sync::Arc;

use rustfft::num_complex::Complex64;
use rustfft::{Fft, FftPlanner};

use crate::error::{CoreError, CoreResult};

mod axes;
mod line;
mod twiddle;

use axes::LINES;

/// Largest grid (points in all): a 3-D 256³ grid.
pub const MAX_POINTS: usize = 1 << 24;

/// Which number of a mode a coordinate is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Part {
    /// The real coefficient of a self-conjugate wavevector.
    Real,
    /// a of a pair: û_j = (a − i b)/√2.
    Cos,
    /// b of a pair.
    Sin,
}

/// One real Fourier coordinate: where its mode sits in the half spectrum.
#[derive(Debug, Clone, Copy)]
pub struct Slot {
    /// Flat index of the representative j in the half spectrum.
    pub at: usize,
    /// Flat index of −j when it is in the half spectrum too (the planes of last index 0 and
    /// n/2), else `usize::MAX`.
    pub mirror: usize,
    pub part: Part,
}

/// Pairs `first`, `first` + 2, … (coordinates) of modes `at`, `at` + 1, …, `len` of them.
#[derive(Debug, Clone, Copy)]
struct PairRun {
    first: usize,
    at: usize,
    len: usize,
}

/// Cuts the slots into runs of unmirrored pairs and single slots (see [`Spectral::runs`]).
fn pair_runs(slots: &[Slot]) -> (Vec<PairRun>, Vec<usize>) {
    let (mut runs, mut singles) = (Vec::<PairRun>::new(), Vec::new());
    let mut i = 0;
    while i < slots.len() {
        let s = slots[i];
        if s.part != Part::Cos || s.mirror != usize::MAX {
            if s.part != Part::Sin {
                singles.push(i);
            }
            i += 1;
            continue;
        }
        match runs.last_mut() {
            Some(r) if r.first + 2 * r.len == i && r.at + r.len == s.at => r.len += 1,
            _ => runs.push(PairRun {
                first: i,
                at: s.at,
                len: 1,
            }),
        }
        i += 2;
    }
    (runs, singles)
}

/// The real Fourier coordinates of one grid shape, with the FFT plans of its two transforms.
pub struct Spectral {
    shape: Vec<usize>,
    /// The half spectrum's shape: `shape` with its last entry n/2 + 1.
    half: Vec<usize>,
    points: usize,
    slots: Vec<Slot>,
    /// The slots as the transforms' packing loops read them: runs of pairs without a mirror
    /// whose coordinates and modes are consecutive (whole rows of the half spectrum), and the
    /// rest one by one.
    runs: Vec<PairRun>,
    singles: Vec<usize>,
    /// The wavevector of each coordinate (signed FFT frequencies, d per coordinate).
    wavevectors: Vec<i64>,
    /// The transforms along the last axis: on a grid of one axis fused with the coordinates'
    /// packing, else row by row of the half spectrum.
    last: line::Line,
    /// Forward and inverse complex FFTs of the first d − 1 axes.
    forward: Vec<Arc<dyn Fft<f64>>>,
    inverse: Vec<Arc<dyn Fft<f64>>>,
}

impl std::fmt::Debug for Spectral {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Spectral({:?})", self.shape)
    }
}

/// Scratch of the two transforms (complex half spectrum and FFT scratch).
#[derive(Default)]
pub struct SpectralWorkspace {
    half: Vec<Complex64>,
    line: Vec<Complex64>,
    scratch: Vec<Complex64>,
}

/// The signed FFT frequency of index k on an axis of n points.
fn frequency(k: usize, n: usize) -> i64 {
    if k <= n / 2 {
        k as i64
    } else {
        k as i64 - n as i64
    }
}

impl Spectral {
    /// The grid of `shape`, planned once per process while anything holds it: a wave problem's
    /// coordinate map and its potential share one (each would otherwise plan its own FFTs).
    pub fn shared(shape: &[usize]) -> CoreResult<Arc<Self>> {
        use std::collections::HashMap;
        use std::sync::{Mutex, OnceLock, Weak};
        static GRIDS: OnceLock<Mutex<HashMap<Vec<usize>, Weak<Spectral>>>> = OnceLock::new();
        let grids = GRIDS.get_or_init(Default::default);
        let mut grids = grids.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(grid) = grids.get(shape).and_then(Weak::upgrade) {
            return Ok(grid);
        }
        let grid = Arc::new(Spectral::new(shape)?);
        // (a grid no longer held is dropped from the table when another is made)
        grids.retain(|_, g| g.strong_count() > 0);
        grids.insert(shape.to_vec(), Arc::downgrade(&grid));
        Ok(grid)
    }

    /// The coordinates of a grid of `shape` points per axis (1 to 3 axes, each even and ≥ 2).
    pub fn new(shape: &[usize]) -> CoreResult<Self> {
        let bad = |reason: String| Err(CoreError::invalid("grid", reason));
        if shape.is_empty() || shape.len() > 3 {
            return bad(format!("1 to 3 axes, got {}", shape.len()));
        }
        if let Some(&n) = shape.iter().find(|&&n| n < 2 || n % 2 != 0) {
            return bad(format!(
                "points per axis must be even and at least 2, got {n} in {shape:?}"
            ));
        }
        let points = shape
            .iter()
            .try_fold(1usize, |a, &n| a.checked_mul(n))
            .filter(|&p| p <= MAX_POINTS);
        let Some(points) = points else {
            return bad(format!(
                "{shape:?} has more than {MAX_POINTS} points (256^3), the largest grid allowed"
            ));
        };
        let d = shape.len();
        let last = shape[d - 1];
        let mut half = shape.to_vec();
        half[d - 1] = last / 2 + 1;
        let half_len: usize = half.iter().product();
        // The multi-index of a flat half-spectrum index, and the flat index of its mirror −j.
        let index = |mut h: usize| {
            let mut idx = [0usize; 3];
            for a in (0..d).rev() {
                idx[a] = h % half[a];
                h /= half[a];
            }
            idx
        };
        let flat = |idx: &[usize; 3]| (0..d).fold(0, |acc, a| acc * half[a] + idx[a]);
        let mut slots = Vec::with_capacity(points);
        let mut wavevectors = Vec::with_capacity(points * d);
        for h in 0..half_len {
            let idx = index(h);
            let k = idx[d - 1];
            let mut j = [0i64; 3];
            for a in 0..d {
                j[a] = frequency(idx[a], shape[a]);
            }
            let mut push = |part: Part, mirror: usize| {
                slots.push(Slot {
                    at: h,
                    mirror,
                    part,
                });
                wavevectors.extend_from_slice(&j[..d]);
            };
            if k != 0 && k != last / 2 {
                push(Part::Cos, usize::MAX);
                push(Part::Sin, usize::MAX);
                continue;
            }
            let mut m = idx;
            for a in 0..d - 1 {
                m[a] = (shape[a] - idx[a]) % shape[a];
            }
            let mh = flat(&m);
            if mh == h {
                push(Part::Real, usize::MAX);
            } else if mh > h {
                push(Part::Cos, mh);
                push(Part::Sin, mh);
            }
        }
        debug_assert_eq!(slots.len(), points);
        let (runs, singles) = pair_runs(&slots);
        let mut complex = FftPlanner::<f64>::new();
        Ok(Spectral {
            last: line::Line::new(last, &mut complex),
            forward: shape[..d - 1]
                .iter()
                .map(|&n| complex.plan_fft_forward(n))
                .collect(),
            inverse: shape[..d - 1]
                .iter()
                .map(|&n| complex.plan_fft_inverse(n))
                .collect(),
            shape: shape.to_vec(),
            half,
            points,
            slots,
            runs,
            singles,
            wavevectors,
        })
    }

    /// Grid points N (= the number of coordinates).
    pub fn points(&self) -> usize {
        self.points
    }

    pub fn shape(&self) -> &[usize] {
        &self.shape
    }

    /// Where each coordinate's mode sits.
    pub fn slots(&self) -> &[Slot] {
        &self.slots
    }

    /// The wavevector of each coordinate, d numbers per coordinate.
    pub fn wavevectors(&self) -> &[i64] {
        &self.wavevectors
    }

    pub fn workspace(&self) -> SpectralWorkspace {
        let longest = self.shape.iter().copied().max().unwrap_or(1);
        let scratch = [
            self.last.scratch_len(),
            self.forward
                .iter()
                .chain(&self.inverse)
                .map(|f| f.get_inplace_scratch_len())
                .max()
                .unwrap_or(0),
        ]
        .into_iter()
        .max()
        .unwrap_or(0);
        SpectralWorkspace {
            half: vec![Complex64::default(); self.half.iter().product()],
            line: vec![Complex64::default(); LINES * longest],
            scratch: vec![Complex64::default(); scratch],
        }
    }

    /// u = S q: the grid values (row-major, N of them) of the coordinates q.
    pub fn to_grid(&self, q: &[f64], u: &mut [f64], ws: &mut SpectralWorkspace) {
        debug_assert_eq!(q.len(), self.points);
        if self.shape.len() == 1 {
            return self.last.to_grid(q, u, &mut ws.half, &mut ws.scratch);
        }
        let r = std::f64::consts::FRAC_1_SQRT_2;
        for run in &self.runs {
            let q = &q[run.first..run.first + 2 * run.len];
            let half = &mut ws.half[run.at..run.at + run.len];
            for (c, ab) in half.iter_mut().zip(q.chunks_exact(2)) {
                *c = Complex64::new(ab[0] * r, -ab[1] * r);
            }
        }
        for &i in &self.singles {
            let s = self.slots[i];
            match s.part {
                Part::Real => ws.half[s.at] = Complex64::new(q[i], 0.0),
                Part::Cos => {
                    let c = Complex64::new(q[i] * r, -q[i + 1] * r);
                    ws.half[s.at] = c;
                    if s.mirror != usize::MAX {
                        ws.half[s.mirror] = c.conj();
                    }
                }
                Part::Sin => {}
            }
        }
        let d = self.shape.len();
        for a in 0..d - 1 {
            self.along_axis(a, self.inverse[a].as_ref(), ws);
        }
        let hl = self.half[d - 1];
        let last = self.shape[d - 1];
        for (row, out) in ws.half.chunks_exact_mut(hl).zip(u.chunks_exact_mut(last)) {
            // The first and last entries of each row are real up to rounding (the mirror
            // symmetry of the planes); the real transform takes them as real.
            self.last.row_to_grid(row, out, &mut ws.scratch);
        }
    }

    /// u = S q for each row of `q` (N numbers per row) into the rows of `u`; with `order`, a
    /// row's coordinate k is the grid's coordinate `order[k]` (a permutation, checked by the
    /// caller).
    pub fn rows_to_grid(
        &self,
        order: Option<&[usize]>,
        q: &[f64],
        u: &mut [f64],
        ws: &mut SpectralWorkspace,
    ) {
        let n = self.points;
        let mut canonical = order.map(|_| vec![0.0; n]);
        for (q, u) in q.chunks_exact(n).zip(u.chunks_exact_mut(n)) {
            let q = match (order, &mut canonical) {
                (Some(order), Some(c)) => {
                    for (&k, &x) in order.iter().zip(q) {
                        c[k] = x;
                    }
                    &c[..]
                }
                _ => q,
            };
            self.to_grid(q, u, ws);
        }
    }

    /// q = Sᵀu / N (the inverse of [`Spectral::rows_to_grid`]) for each row of `u`, in
    /// `order` as there.
    pub fn rows_from_grid(
        &self,
        order: Option<&[usize]>,
        u: &[f64],
        q: &mut [f64],
        ws: &mut SpectralWorkspace,
    ) {
        let n = self.points;
        // the transform overwrites its input (a copy of the row, filled below: not zeroed first)
        let mut row = Vec::with_capacity(n);
        let mut canonical = order.map(|_| vec![0.0; n]);
        for (u, q) in u.chunks_exact(n).zip(q.chunks_exact_mut(n)) {
            row.clear();
            row.extend_from_slice(u);
            match (order, &mut canonical) {
                (Some(order), Some(c)) => {
                    self.transpose(&mut row, c, 1.0 / n as f64, ws);
                    for (x, &k) in q.iter_mut().zip(order) {
                        *x = c[k];
                    }
                }
                _ => self.transpose(&mut row, q, 1.0 / n as f64, ws),
            }
        }
    }

    /// out = scale · Sᵀ w for grid values w (row-major, N of them). `w` is used as scratch.
    pub fn transpose(
        &self,
        w: &mut [f64],
        out: &mut [f64],
        scale: f64,
        ws: &mut SpectralWorkspace,
    ) {
        if self.shape.len() == 1 {
            return self
                .last
                .transpose(w, out, scale, &mut ws.half, &mut ws.scratch);
        }
        let d = self.shape.len();
        let hl = self.half[d - 1];
        let last = self.shape[d - 1];
        for (row, input) in ws.half.chunks_exact_mut(hl).zip(w.chunks_exact_mut(last)) {
            self.last.row_from_grid(input, row, &mut ws.scratch);
        }
        for a in 0..d - 1 {
            self.along_axis(a, self.forward[a].as_ref(), ws);
        }
        let s2 = std::f64::consts::SQRT_2 * scale;
        for run in &self.runs {
            let out = &mut out[run.first..run.first + 2 * run.len];
            let half = &ws.half[run.at..run.at + run.len];
            for (ab, c) in out.chunks_exact_mut(2).zip(half) {
                ab[0] = c.re * s2;
                ab[1] = -c.im * s2;
            }
        }
        for &i in &self.singles {
            let s = self.slots[i];
            let c = ws.half[s.at];
            match s.part {
                Part::Real => out[i] = c.re * scale,
                Part::Cos => {
                    out[i] = c.re * s2;
                    out[i + 1] = -c.im * s2;
                }
                Part::Sin => {}
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid_values(shape: &[usize], seed: f64) -> Vec<f64> {
        let n: usize = shape.iter().product();
        (0..n)
            .map(|k| ((k as f64 + 1.0) * seed).sin() + 0.3 * ((k * k) as f64 * 0.01).cos())
            .collect()
    }

    #[test]
    fn the_map_is_orthogonal_up_to_the_number_of_points() {
        for shape in [vec![8], vec![2], vec![6, 4], vec![4, 2, 6], vec![2, 2]] {
            let s = Spectral::new(&shape).unwrap();
            let n = s.points();
            let mut ws = s.workspace();
            let u = grid_values(&shape, 0.7);
            // q = Sᵀu / N, then S q = u: the inverse.
            let mut q = vec![0.0; n];
            s.transpose(&mut u.clone(), &mut q, 1.0 / n as f64, &mut ws);
            let mut back = vec![0.0; n];
            s.to_grid(&q, &mut back, &mut ws);
            for k in 0..n {
                assert!((back[k] - u[k]).abs() < 1e-13, "{shape:?} point {k}");
            }
            // mean_x u² = |q|².
            let mean: f64 = u.iter().map(|x| x * x).sum::<f64>() / n as f64;
            let norm: f64 = q.iter().map(|x| x * x).sum();
            assert!((mean - norm).abs() < 1e-13 * mean, "{shape:?}");
        }
    }

    #[test]
    fn a_coordinate_is_its_cosine_or_sine_on_the_grid() {
        // 1-D, n = 8: the pair of j = 3 is √2 cos(3x), √2 sin(3x); j = 4 is cos(4x) = ±1.
        let s = Spectral::new(&[8]).unwrap();
        let mut ws = s.workspace();
        for (i, slot) in s.slots().iter().enumerate() {
            let j = s.wavevectors()[i] as f64;
            let mut e = vec![0.0; 8];
            e[i] = 1.0;
            let mut u = vec![0.0; 8];
            s.to_grid(&e, &mut u, &mut ws);
            for k in 0..8 {
                let x = 2.0 * std::f64::consts::PI * k as f64 / 8.0;
                let want = match slot.part {
                    Part::Real => (j * x).cos(),
                    Part::Cos => 2f64.sqrt() * (j * x).cos(),
                    Part::Sin => 2f64.sqrt() * (j * x).sin(),
                };
                assert!((u[k] - want).abs() < 1e-14, "coordinate {i} point {k}");
            }
        }
    }

    #[test]
    fn lines_in_groups_give_the_bits_of_lines_alone() {
        // half spectra of 6 × 6, 8 × 10 × 3, 10 × 4 × 4, 2 × 5 and 4 × 6 × 6: groups of four
        // lines and the rest, axes of 2 points, several outer blocks with both
        let shapes = [
            vec![6, 10],
            vec![8, 10, 4],
            vec![10, 4, 6],
            vec![2, 8],
            vec![4, 6, 10],
        ];
        for shape in shapes {
            let s = Spectral::new(&shape).unwrap();
            let d = shape.len();
            for (axis, forward) in (0..d - 1).flat_map(|a| [(a, true), (a, false)]) {
                let fft = if forward {
                    &s.forward[axis]
                } else {
                    &s.inverse[axis]
                };
                let mut ws = s.workspace();
                let len = ws.half.len();
                let values: Vec<Complex64> = (0..len)
                    .map(|k| Complex64::new((0.3 * k as f64).sin(), (0.7 * k as f64).cos()))
                    .collect();
                ws.half.copy_from_slice(&values);
                s.along_axis(axis, fft.as_ref(), &mut ws);
                // each line alone
                let (n, stride) = (s.half[axis], s.half[axis + 1..].iter().product::<usize>());
                let mut expected = values.clone();
                for o in 0..len / (n * stride) {
                    for c in 0..stride {
                        let at = |i: usize| o * n * stride + c + i * stride;
                        let mut line: Vec<Complex64> = (0..n).map(|i| values[at(i)]).collect();
                        fft.process(&mut line);
                        for (i, x) in line.into_iter().enumerate() {
                            expected[at(i)] = x;
                        }
                    }
                }
                let bits = |v: &[Complex64]| -> Vec<u64> {
                    v.iter()
                        .flat_map(|c| [c.re.to_bits(), c.im.to_bits()])
                        .collect()
                };
                let case = format!("{shape:?}, axis {axis}, forward {forward}");
                assert_eq!(bits(&ws.half), bits(&expected), "{case}");
            }
        }
    }

    #[test]
    fn bad_grids_are_refused() {
        for shape in [vec![], vec![3], vec![0], vec![4, 5], vec![2, 2, 2, 2]] {
            assert!(Spectral::new(&shape).is_err(), "{shape:?}");
        }
        assert!(Spectral::new(&[1 << 13, 1 << 12]).is_err());
        assert!(Spectral::shared(&[3]).is_err());
    }

    #[test]
    fn a_shape_is_planned_once_while_it_is_held() {
        let a = Spectral::shared(&[6, 10]).unwrap();
        let b = Spectral::shared(&[6, 10]).unwrap();
        assert!(Arc::ptr_eq(&a, &b));
        assert!(!Arc::ptr_eq(&a, &Spectral::shared(&[10, 6]).unwrap()));
        let weak = Arc::downgrade(&a);
        drop((a, b));
        // nothing holds it: it is freed, and the next request plans it again
        assert!(weak.upgrade().is_none());
        assert_eq!(Spectral::shared(&[6, 10]).unwrap().points(), 60);
    }
}

//! Pair forms: K_m = Σ_k w_mk (q_a p_b − q_b p_a), the momentum of a wave equation, with the
//! runs of pairs that the observing sweep takes them along in.

use crate::error::{CoreError, CoreResult};
use crate::real::Real;
use crate::sum::Sum8;

/// A bilinear invariant per axis, K_m = Σ_k w_mk (q_a p_b − q_b p_a) over index pairs (a_k, b_k)
/// of the kernels' coordinates: the momentum of a wave equation in real Fourier coordinates
/// (a, b the cosine and sine coordinates of a mode, w_mk its wavenumber along axis m). Its
/// channels are the table's per-axis entries ([`crate::channels`]). A grid without complex
/// modes (2 points per axis) has no pairs: its K_m are the empty sum, 0.
#[derive(Debug, Clone, PartialEq)]
pub struct PairForms {
    a: Vec<usize>,
    b: Vec<usize>,
    /// Axis-major: weights[m * pairs + k].
    weights: Vec<f64>,
    /// The number of axes m (channels).
    axes: usize,
    /// The pairs as runs of consecutive ones when every pair is (a, a + 1) and they come in
    /// the coordinates' order: the modes of a wave equation of any dimension, read without an
    /// index (see [`PairForms::riding`]). Empty otherwise.
    runs: Vec<RunOfPairs>,
}

/// Pairs `first`, `first` + 1, …, `len` of them, on the coordinates (`at`, `at` + 1),
/// (`at` + 2, `at` + 3), ….
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RunOfPairs {
    pub at: usize,
    pub first: usize,
    pub len: usize,
}

/// The runs of [`PairForms::runs`]: empty unless every b = a + 1 and every a is at least two
/// above the one before.
fn pair_runs(a: &[usize], b: &[usize]) -> Vec<RunOfPairs> {
    let adjacent = a.iter().zip(b).all(|(&a, &b)| b == a + 1);
    if !adjacent || a.windows(2).any(|w| w[1] < w[0] + 2) {
        return Vec::new();
    }
    let mut runs: Vec<RunOfPairs> = Vec::new();
    for (t, &at) in a.iter().enumerate() {
        match runs.last_mut() {
            Some(r) if r.at + 2 * r.len == at => r.len += 1,
            _ => runs.push(RunOfPairs {
                at,
                first: t,
                len: 1,
            }),
        }
    }
    runs
}

/// Axes of the pair forms the observing sweep of many blocks takes along (a wave equation's
/// momentum has d ≤ 3).
pub const MAX_RIDING_AXES: usize = 3;

impl PairForms {
    /// Checks the pairs against n coordinates and the weights against the pairs and `axes`.
    pub fn new(
        a: Vec<usize>,
        b: Vec<usize>,
        weights: Vec<f64>,
        axes: usize,
        n: usize,
    ) -> CoreResult<Self> {
        let bad = |reason: String| Err(CoreError::invalid("pair forms", reason));
        if a.len() != b.len() {
            return bad(format!("{} first and {} second indices", a.len(), b.len()));
        }
        if let Some(i) = a.iter().chain(&b).find(|&&i| i >= n) {
            return bad(format!("index {i} is not below the {n} coordinates"));
        }
        if axes == 0 || weights.len() != axes * a.len() {
            return bad(format!(
                "{} weights for {} pairs and {axes} axes (one weight per pair and axis, at \
                 least one axis)",
                weights.len(),
                a.len()
            ));
        }
        if let Some(w) = weights.iter().find(|w| !w.is_finite()) {
            return bad(format!("weight {w} is not finite"));
        }
        let runs = pair_runs(&a, &b);
        Ok(PairForms {
            a,
            b,
            weights,
            axes,
            runs,
        })
    }

    /// Number of axes (channels).
    pub fn axes(&self) -> usize {
        self.axes
    }

    /// a₀ when the pairs are (a₀, a₀ + 1), (a₀ + 2, a₀ + 3), …, one run: the modes of a 1-D wave
    /// equation in the grid's order, read without an index (see [`PairForms::evaluate`]).
    fn consecutive(&self) -> Option<usize> {
        match self.runs[..] {
            [run] => Some(run.at),
            _ => None,
        }
    }

    /// The pairs (a_k, b_k), checked at construction (the fields are private, so that the runs
    /// found there stay the pairs' runs).
    pub fn pairs(&self) -> (&[usize], &[usize]) {
        (&self.a, &self.b)
    }

    /// The weights, axis-major: `weights()[m * pairs + k]`.
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }

    /// The runs of pairs (in the pairs' order) when the observing sweep of these blocks can
    /// compute the forms in its pass (its riders, recursion/blocks.rs): every pair (a, a + 1),
    /// in the coordinates' order, at most [`MAX_RIDING_AXES`] axes. None otherwise, or without
    /// pairs.
    pub fn riding(&self) -> Option<&[RunOfPairs]> {
        (!self.runs.is_empty() && self.axes() <= MAX_RIDING_AXES).then_some(&self.runs[..])
    }

    /// Whether the forms can ride along the sweep of the blocks ending at `ends` over the
    /// oscillatory coordinates from `ns` on (see [`PairForms::riding`]): also, every pair among
    /// them and none split by a block end.
    pub fn rides_along(&self, ns: usize, ends: &[usize]) -> bool {
        if self.riding().is_none() {
            return false;
        }
        let (first, last) = (self.a[0], self.b[self.b.len() - 1]);
        if first < ns || ends.last().is_none_or(|&e| e <= last) {
            return false;
        }
        // No block ends between the two coordinates of a pair, at a + 1: one walk over the two
        // ascending lists.
        let mut t = 0;
        ends.iter().all(|&e| {
            while t < self.a.len() && self.a[t] + 1 < e {
                t += 1;
            }
            t == self.a.len() || self.a[t] + 1 != e
        })
    }

    /// K_m of the state (q, p) into `out[m]`, each a sum in the kernels' fixed order.
    pub fn evaluate<L: Real>(&self, q: &[L], p: &[L], out: &mut [L]) {
        let pairs = self.a.len();
        if let Some(a0) = self.consecutive() {
            // The same terms in the same order, from two contiguous slices.
            let (q, p) = (&q[a0..a0 + 2 * pairs], &p[a0..a0 + 2 * pairs]);
            for (m, k) in out.iter_mut().enumerate() {
                let w = &self.weights[m * pairs..(m + 1) * pairs];
                let mut sum = Sum8::new();
                let term = |t: usize| {
                    let (qa, qb, pa, pb) = (q[2 * t], q[2 * t + 1], p[2 * t], p[2 * t + 1]);
                    L::splat(w[t]) * (qa * pb - qb * pa)
                };
                let whole = pairs / 8 * 8;
                for base in (0..whole).step_by(8) {
                    let x: [L; 8] = std::array::from_fn(|t| term(base + t));
                    if base == 0 {
                        sum.add8::<true>(&x);
                    } else {
                        sum.add8::<false>(&x);
                    }
                }
                for t in whole..pairs {
                    sum.add(t % 8, t >= 8, term(t));
                }
                *k = sum.total(pairs);
            }
            return;
        }
        for (m, k) in out.iter_mut().enumerate() {
            let w = &self.weights[m * pairs..(m + 1) * pairs];
            let mut sum = Sum8::new();
            for (t, ((&a, &b), &wt)) in self.a.iter().zip(&self.b).zip(w).enumerate() {
                sum.add(t % 8, t >= 8, L::splat(wt) * (q[a] * p[b] - q[b] * p[a]));
            }
            *k = sum.total(pairs);
        }
    }
}

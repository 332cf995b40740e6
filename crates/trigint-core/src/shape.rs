//! How the coordinates of a problem are arranged inside the kernels.
//!
//! The kernels see the coordinates sorted: the slow ones first (ω = 0, block 0), then each
//! oscillatory block as a contiguous range. (The Python layer permutes into this order and back,
//! or, for a stiffness matrix, the modal coordinates are built in it.) A loop over the slow
//! coordinates or over a block is then a loop over a range, and for small problems that range is
//! a compile-time constant: the state lives in registers and the slow coordinates run
//! Störmer–Verlet's arithmetic without the zero coefficients of a general row.

use crate::energy::PairForms;
use crate::error::{CoreError, CoreResult};
use crate::real::{first_failing, Real};

/// One number per coordinate: a fixed-size array (small problems) or a vector.
pub trait Storage<L>: Clone + Send + Sync + 'static {
    fn filled(n: usize, value: L) -> Self;
    /// The numbers f(0), …, f(n − 1), each written once (a vector is not zeroed first).
    fn from_fn(n: usize, f: impl FnMut(usize) -> L) -> Self;
    /// The storage of these numbers (as many as the storage holds), the vector's own memory
    /// where the storage is a vector.
    fn from_vec(v: Vec<L>) -> Self;
    /// A placeholder that owns nothing (an empty vector, or zeros).
    fn placeholder() -> Self;
    fn get(&self) -> &[L];
    fn get_mut(&mut self) -> &mut [L];
}

impl<L: Real, const N: usize> Storage<L> for [L; N] {
    #[inline(always)]
    fn filled(n: usize, value: L) -> Self {
        debug_assert_eq!(n, N);
        [value; N]
    }
    #[inline(always)]
    fn from_fn(n: usize, f: impl FnMut(usize) -> L) -> Self {
        debug_assert_eq!(n, N);
        std::array::from_fn(f)
    }
    #[inline(always)]
    fn from_vec(v: Vec<L>) -> Self {
        let mut a = [L::zero(); N];
        a.copy_from_slice(&v);
        a
    }
    #[inline(always)]
    fn placeholder() -> Self {
        [L::zero(); N]
    }
    #[inline(always)]
    fn get(&self) -> &[L] {
        self
    }
    #[inline(always)]
    fn get_mut(&mut self) -> &mut [L] {
        self
    }
}

impl<L: Real> Storage<L> for Vec<L> {
    fn filled(n: usize, value: L) -> Self {
        vec![value; n]
    }
    fn from_fn(n: usize, f: impl FnMut(usize) -> L) -> Self {
        (0..n).map(f).collect()
    }
    fn from_vec(v: Vec<L>) -> Self {
        v
    }
    fn placeholder() -> Self {
        Vec::new()
    }
    #[inline(always)]
    fn get(&self) -> &[L] {
        self
    }
    #[inline(always)]
    fn get_mut(&mut self) -> &mut [L] {
        self
    }
}

/// The arrangement of the coordinates: n of them, the first `ns` slow, the rest in ℓ blocks.
pub trait Shape: Clone + Send + Sync {
    type S<L: Real>: Storage<L>;
    /// Sizes known at compile time (every index is then a constant below N).
    const FIXED: bool;
    /// Number of coordinates n.
    fn n(&self) -> usize;
    /// Number of slow coordinates; they are 0..ns.
    fn ns(&self) -> usize;
    /// Where each oscillatory block ends: block j is `ends[j-1]..ends[j]` with `ends[-1] = ns`.
    /// Empty when there is no oscillatory coordinate.
    fn block_ends(&self) -> &[usize];
    /// ℓ ≤ 1: the oscillatory coordinates form at most one block (then I_1 = H_ω).
    fn single_block(&self) -> bool {
        self.block_ends().len() <= 1
    }
    /// The most coordinates of one oscillatory block (0 without any).
    fn longest_block(&self) -> usize {
        longest_block(self.ns(), self.block_ends())
    }
    /// Where oscillatory coordinate i reads its per-coordinate numbers: i itself, or for a
    /// [`Fixed`] or [`Uniform`] shape, whose one block has the same numbers throughout, its
    /// first coordinate (fewer distinct numbers to keep in registers and to read). Always
    /// ns ≤ coef(i) ≤ i: the kernels rely on it to read without bounds tests.
    #[inline(always)]
    fn coef(&self, i: usize) -> usize {
        self.uniform().unwrap_or(i)
    }
    /// Where every oscillatory coordinate reads its numbers, when they are one for the block
    /// ([`Fixed`], [`Uniform`]): the kernels then load them once, before their loops.
    #[inline(always)]
    fn uniform(&self) -> Option<usize> {
        None
    }
}

/// N coordinates, the first NS slow and the others one block whose coordinates share their
/// method numbers and frequency: everything known at compile time.
#[derive(Clone, Copy, Debug)]
pub struct Fixed<const N: usize, const NS: usize> {
    ends: [usize; 1],
    blocks: usize,
}

impl<const N: usize, const NS: usize> Fixed<N, NS> {
    pub fn new() -> Self {
        Fixed {
            ends: [N],
            blocks: usize::from(NS < N),
        }
    }
}

impl<const N: usize, const NS: usize> Default for Fixed<N, NS> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize, const NS: usize> Shape for Fixed<N, NS> {
    type S<L: Real> = [L; N];
    const FIXED: bool = true;
    #[inline(always)]
    fn n(&self) -> usize {
        N
    }
    #[inline(always)]
    fn ns(&self) -> usize {
        NS
    }
    #[inline(always)]
    fn block_ends(&self) -> &[usize] {
        &self.ends[..self.blocks]
    }
    #[inline(always)]
    fn single_block(&self) -> bool {
        true
    }
    #[inline(always)]
    fn uniform(&self) -> Option<usize> {
        Some(NS)
    }
}

/// The most coordinates of one block, from where the blocks end (block j is
/// `ends[j-1]..ends[j]`, `ends[-1] = ns`).
fn longest_block(ns: usize, ends: &[usize]) -> usize {
    let mut start = ns;
    let mut longest = 0;
    for &end in ends {
        longest = longest.max(end - start);
        start = end;
    }
    longest
}

/// Any arrangement, sizes known at run time.
#[derive(Clone, Debug)]
pub struct Dynamic {
    n: usize,
    ns: usize,
    ends: Vec<usize>,
    /// [`Shape::longest_block`], counted once (a wave equation has 10⁴–10⁶ blocks).
    longest: usize,
}

impl Shape for Dynamic {
    type S<L: Real> = Vec<L>;
    const FIXED: bool = false;
    #[inline(always)]
    fn n(&self) -> usize {
        self.n
    }
    #[inline(always)]
    fn ns(&self) -> usize {
        self.ns
    }
    #[inline(always)]
    fn block_ends(&self) -> &[usize] {
        &self.ends
    }
    #[inline(always)]
    fn longest_block(&self) -> usize {
        self.longest
    }
}

/// Sizes known at run time, one oscillatory block whose coordinates share their method numbers
/// and frequency (read once, as for [`Fixed`]): long chains of one stiff frequency.
#[derive(Clone, Debug)]
pub struct Uniform {
    n: usize,
    ns: usize,
    ends: Vec<usize>,
}

impl Shape for Uniform {
    type S<L: Real> = Vec<L>;
    const FIXED: bool = false;
    #[inline(always)]
    fn n(&self) -> usize {
        self.n
    }
    #[inline(always)]
    fn ns(&self) -> usize {
        self.ns
    }
    #[inline(always)]
    fn block_ends(&self) -> &[usize] {
        &self.ends
    }
    #[inline(always)]
    fn single_block(&self) -> bool {
        true
    }
    #[inline(always)]
    fn uniform(&self) -> Option<usize> {
        // None when every coordinate is slow: there is no oscillatory number to read.
        (self.ns < self.n).then_some(self.ns)
    }
}

/// The problem's arrangement and the frequencies that weigh the energies.
#[derive(Debug, Clone)]
pub struct Layout {
    /// ω_i² per coordinate (0 on the slow ones).
    pub omega2: Vec<f64>,
    /// Number of slow coordinates (they come first).
    pub n_slow: usize,
    /// End of each oscillatory block (increasing, the last one = n).
    pub block_ends: Vec<usize>,
    /// A bilinear invariant streamed with the energies (the momentum of a wave equation), or
    /// None.
    pub pair_forms: Option<PairForms>,
}

impl Layout {
    pub fn dim(&self) -> usize {
        self.omega2.len()
    }

    /// Number of per-axis channels (0 without pair forms).
    pub fn n_axes(&self) -> usize {
        self.pair_forms.as_ref().map_or(0, |p| p.axes())
    }

    /// ℓ, the number of oscillatory blocks.
    pub fn n_blocks(&self) -> usize {
        self.block_ends.len()
    }

    pub fn validate(&self) -> CoreResult<()> {
        let n = self.dim();
        let bad = |reason: String| Err(CoreError::invalid("layout", reason));
        if n == 0 {
            return bad("need at least one coordinate".into());
        }
        if self.n_slow > n {
            return bad(format!("{} slow coordinates of {n}", self.n_slow));
        }
        let mut start = self.n_slow;
        for &end in &self.block_ends {
            if end <= start || end > n {
                return bad(format!(
                    "block ends {:?} must increase from {} to {n}",
                    self.block_ends, self.n_slow
                ));
            }
            start = end;
        }
        if start != n {
            return bad(format!(
                "the blocks end at {start}, not at the last coordinate {n}"
            ));
        }
        if let Some(i) = first_failing(&self.omega2, |w| w.is_finite() && w >= 0.0) {
            return bad(format!("omega^2 of coordinate {i} is {}", self.omega2[i]));
        }
        if let Some(i) = (0..self.n_slow).find(|&i| self.omega2[i] != 0.0) {
            return bad(format!("slow coordinate {i} has a non-zero frequency"));
        }
        if let Some(f) = &self.pair_forms {
            if let Some(i) = f.pairs().0.iter().chain(f.pairs().1).find(|&&i| i >= n) {
                return bad(format!(
                    "pair form index {i} is not below the {n} coordinates"
                ));
            }
        }
        if let Some(i) =
            first_failing(&self.omega2[self.n_slow..], |w| w != 0.0).map(|i| i + self.n_slow)
        {
            return bad(format!(
                "oscillatory coordinate {i} has frequency 0; it belongs to the slow ones"
            ));
        }
        Ok(())
    }

    /// The run-time shape of a layout with at most one block whose numbers are uniform.
    pub fn uniform(&self) -> Uniform {
        debug_assert!(self.block_ends.len() <= 1);
        Uniform {
            n: self.dim(),
            ns: self.n_slow,
            ends: self.block_ends.clone(),
        }
    }

    /// The run-time shape of this layout.
    pub fn dynamic(&self) -> Dynamic {
        Dynamic {
            n: self.dim(),
            ns: self.n_slow,
            ends: self.block_ends.clone(),
            longest: longest_block(self.n_slow, &self.block_ends),
        }
    }
}

//! The number type the kernels are written in: one trajectory (`f64`) or a bundle of W
//! trajectories ([`Lanes<W>`]) stepped together.
//!
//! Every kernel, every potential and every energy form is written once over [`Real`]. A
//! `Lanes<W>` operation is the `f64` operation applied to each lane, so lane b of a bundle gets
//! exactly the bits that the same code computes on `f64` for that trajectory alone. Rust never
//! contracts a·b + c into a fused multiply-add, so the vectorized code (SSE, AVX2, AVX-512,
//! chosen at run time) gives the same bits as the scalar code too.

use std::ops::{
    Add, AddAssign, BitAnd, BitOr, BitOrAssign, Div, Mul, MulAssign, Neg, Sub, SubAssign,
};

/// The most lanes a bundle may have: the size of a [`LaneSet`].
pub const MAX_LANES: usize = 256;
const WORDS: usize = MAX_LANES / 64;

/// A set of a bundle's lanes (which are still running, which are not finite): one bit per lane.
///
/// A fixed 256 bits, so the same code serves bundles of 1 to [`MAX_LANES`] lanes; in a kernel
/// of 8 lanes the three upper words are constant zeros that the compiler folds away.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LaneSet([u64; WORDS]);

impl LaneSet {
    pub const EMPTY: LaneSet = LaneSet([0; WORDS]);

    /// Lanes 0 .. count (count ≤ [`MAX_LANES`]).
    #[inline]
    pub fn first(count: usize) -> Self {
        assert!(count <= MAX_LANES, "a bundle has at most {MAX_LANES} lanes");
        let mut s = Self::EMPTY;
        for (w, word) in s.0.iter_mut().enumerate() {
            let bits = count.saturating_sub(64 * w).min(64);
            *word = if bits == 64 {
                u64::MAX
            } else {
                (1u64 << bits) - 1
            };
        }
        s
    }

    /// Adds lane b when `yes` (branch-free, for lane loops).
    #[inline(always)]
    pub fn insert_if(&mut self, b: usize, yes: bool) {
        self.0[b / 64] |= u64::from(yes) << (b % 64);
    }

    #[inline(always)]
    pub fn remove(&mut self, b: usize) {
        self.0[b / 64] &= !(1u64 << (b % 64));
    }

    #[inline(always)]
    pub fn contains(self, b: usize) -> bool {
        self.0[b / 64] >> (b % 64) & 1 == 1
    }

    #[inline(always)]
    pub fn is_empty(self) -> bool {
        self.0.iter().all(|&w| w == 0)
    }

    /// The lanes in the set, in increasing order (word by word, bit by bit: the cost is the
    /// number of lanes in the set, not the size of the set).
    pub fn iter(self) -> impl Iterator<Item = usize> {
        self.0.into_iter().enumerate().flat_map(|(w, mut bits)| {
            std::iter::from_fn(move || {
                (bits != 0).then(|| {
                    let b = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    64 * w + b
                })
            })
        })
    }
}

impl BitAnd for LaneSet {
    type Output = Self;
    #[inline(always)]
    fn bitand(self, o: Self) -> Self {
        LaneSet(std::array::from_fn(|w| self.0[w] & o.0[w]))
    }
}

impl BitOr for LaneSet {
    type Output = Self;
    #[inline(always)]
    fn bitor(self, o: Self) -> Self {
        LaneSet(std::array::from_fn(|w| self.0[w] | o.0[w]))
    }
}

impl BitOrAssign for LaneSet {
    #[inline(always)]
    fn bitor_assign(&mut self, o: Self) {
        *self = *self | o;
    }
}

/// Arithmetic on one number per trajectory.
pub trait Real:
    Copy
    + Send
    + Sync
    + 'static
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
{
    /// Trajectories per value.
    const LANES: usize;
    fn splat(x: f64) -> Self;
    fn lane(&self, b: usize) -> f64;
    fn set_lane(&mut self, b: usize, x: f64);
    /// `if e > self { e } else { self }` per lane: a running maximum that a NaN never enters.
    fn keep_max(self, e: Self) -> Self;
    /// `if e < self { e } else { self }` per lane.
    fn keep_min(self, e: Self) -> Self;
    /// The lanes that are not finite (their exponent bits are all ones).
    fn nonfinite_lanes(self) -> LaneSet;
    /// IEEE square root per lane (correctly rounded, so the same bits everywhere).
    fn sqrt(self) -> Self;
    fn abs(self) -> Self;
    /// A scalar function applied lane by lane (exp, sin, …: the same libm call per lane).
    fn map(self, f: fn(f64) -> f64) -> Self;
    /// `f(x, y)` lane by lane.
    fn map2(self, other: Self, f: fn(f64, f64) -> f64) -> Self;

    /// The numbers as plain `f64`s, lane b of value i at `i * LANES + b`, for machine code that
    /// reads and writes them in place; None where a value holds padding (a bundle whose lanes
    /// do not fill its 64-byte alignment).
    #[inline(always)]
    fn as_f64s(_x: &[Self]) -> Option<&[f64]> {
        None
    }
    #[inline(always)]
    fn as_f64s_mut(_x: &mut [Self]) -> Option<&mut [f64]> {
        None
    }
    /// A vector of `f64`s as a vector of this type, taken over without a copy where the type
    /// is `f64` itself; otherwise handed back.
    #[inline(always)]
    fn vec_from_f64s(v: Vec<f64>) -> Result<Vec<Self>, Vec<f64>> {
        Err(v)
    }

    #[inline(always)]
    fn zero() -> Self {
        Self::splat(0.0)
    }
}

const EXPONENT: u64 = 0x7ff0_0000_0000_0000;

impl Real for f64 {
    const LANES: usize = 1;

    #[inline(always)]
    fn splat(x: f64) -> Self {
        x
    }
    #[inline(always)]
    fn lane(&self, _: usize) -> f64 {
        *self
    }
    #[inline(always)]
    fn set_lane(&mut self, _: usize, x: f64) {
        *self = x;
    }
    #[inline(always)]
    fn keep_max(self, e: Self) -> Self {
        if e > self {
            e
        } else {
            self
        }
    }
    #[inline(always)]
    fn keep_min(self, e: Self) -> Self {
        if e < self {
            e
        } else {
            self
        }
    }
    #[inline(always)]
    fn nonfinite_lanes(self) -> LaneSet {
        let mut s = LaneSet::EMPTY;
        s.insert_if(0, self.to_bits() & EXPONENT == EXPONENT);
        s
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f64::abs(self)
    }
    #[inline(always)]
    fn map(self, f: fn(f64) -> f64) -> Self {
        f(self)
    }
    #[inline(always)]
    fn map2(self, other: Self, f: fn(f64, f64) -> f64) -> Self {
        f(self, other)
    }
    #[inline(always)]
    fn as_f64s(x: &[Self]) -> Option<&[f64]> {
        Some(x)
    }
    #[inline(always)]
    fn as_f64s_mut(x: &mut [Self]) -> Option<&mut [f64]> {
        Some(x)
    }
    #[inline(always)]
    fn vec_from_f64s(v: Vec<f64>) -> Result<Vec<Self>, Vec<f64>> {
        Ok(v)
    }
}

/// One trajectory's number, for the one-lane kernel.
///
/// Every operation's result passes through [`opaque`]: the value is unchanged and no instruction
/// is emitted, but the optimizer cannot see into it. Otherwise LLVM's SLP vectorizer packs the
/// independent coordinate chains of one trajectory into vector registers, and the shuffles it
/// needs lengthen the step's critical path (FPU, m = 3: 13.9 ns per step packed, 10.2 ns not).
/// A bundle of lanes ([`Lanes`]) is a vector already and is left to the vectorizer.
#[derive(Clone, Copy, Debug, PartialEq, PartialOrd, Default)]
#[repr(transparent)]
pub struct Scalar(pub f64);

/// `x` unchanged, opaque to the optimizer.
#[inline(always)]
pub fn opaque(x: f64) -> f64 {
    #[cfg(target_arch = "x86_64")]
    {
        let mut x = x;
        // SAFETY: an empty instruction sequence naming one register; it reads and writes nothing
        // else.
        unsafe {
            std::arch::asm!("/* {0} */", inout(xmm_reg) x, options(pure, nomem, nostack, preserves_flags));
        }
        x
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        x
    }
}

macro_rules! scalar_op {
    ($trait:ident, $method:ident, $op:tt, $assign_trait:ident, $assign:ident) => {
        impl $trait for Scalar {
            type Output = Self;
            #[inline(always)]
            fn $method(self, o: Self) -> Self {
                Scalar(opaque(self.0 $op o.0))
            }
        }
        impl $assign_trait for Scalar {
            #[inline(always)]
            fn $assign(&mut self, o: Self) {
                self.0 = opaque(self.0 $op o.0);
            }
        }
    };
}

scalar_op!(Add, add, +, AddAssign, add_assign);
scalar_op!(Sub, sub, -, SubAssign, sub_assign);
scalar_op!(Mul, mul, *, MulAssign, mul_assign);

impl Div for Scalar {
    type Output = Self;
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        Scalar(opaque(self.0 / o.0))
    }
}

impl Neg for Scalar {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Scalar(opaque(-self.0))
    }
}

impl Real for Scalar {
    const LANES: usize = 1;
    #[inline(always)]
    fn splat(x: f64) -> Self {
        Scalar(x)
    }
    #[inline(always)]
    fn lane(&self, _: usize) -> f64 {
        self.0
    }
    #[inline(always)]
    fn set_lane(&mut self, _: usize, x: f64) {
        self.0 = x;
    }
    #[inline(always)]
    fn keep_max(self, e: Self) -> Self {
        Scalar(opaque(self.0.keep_max(e.0)))
    }
    #[inline(always)]
    fn keep_min(self, e: Self) -> Self {
        Scalar(opaque(self.0.keep_min(e.0)))
    }
    #[inline(always)]
    fn nonfinite_lanes(self) -> LaneSet {
        self.0.nonfinite_lanes()
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        Scalar(opaque(self.0.sqrt()))
    }
    #[inline(always)]
    fn abs(self) -> Self {
        Scalar(opaque(self.0.abs()))
    }
    #[inline(always)]
    fn map(self, f: fn(f64) -> f64) -> Self {
        Scalar(f(self.0))
    }
    #[inline(always)]
    fn map2(self, other: Self, f: fn(f64, f64) -> f64) -> Self {
        Scalar(f(self.0, other.0))
    }
    #[inline(always)]
    fn as_f64s(x: &[Self]) -> Option<&[f64]> {
        // SAFETY: Scalar is repr(transparent) over f64.
        Some(unsafe { std::slice::from_raw_parts(x.as_ptr().cast::<f64>(), x.len()) })
    }
    #[inline(always)]
    fn as_f64s_mut(x: &mut [Self]) -> Option<&mut [f64]> {
        // SAFETY: Scalar is repr(transparent) over f64; the borrow is handed on.
        Some(unsafe { std::slice::from_raw_parts_mut(x.as_mut_ptr().cast::<f64>(), x.len()) })
    }
}

/// W trajectories' numbers, one per lane; 64-byte aligned so a bundle of 8 is one AVX-512
/// register and never straddles a cache line.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct Lanes<const W: usize>(pub [f64; W]);

macro_rules! lanewise {
    ($trait:ident, $method:ident, $op:tt, $assign_trait:ident, $assign:ident) => {
        impl<const W: usize> $trait for Lanes<W> {
            type Output = Self;
            #[inline(always)]
            fn $method(self, o: Self) -> Self {
                let mut r = [0.0; W];
                for b in 0..W {
                    r[b] = self.0[b] $op o.0[b];
                }
                Lanes(r)
            }
        }
        impl<const W: usize> $assign_trait for Lanes<W> {
            #[inline(always)]
            fn $assign(&mut self, o: Self) {
                for b in 0..W {
                    self.0[b] = self.0[b] $op o.0[b];
                }
            }
        }
    };
}

lanewise!(Add, add, +, AddAssign, add_assign);
lanewise!(Sub, sub, -, SubAssign, sub_assign);
lanewise!(Mul, mul, *, MulAssign, mul_assign);

impl<const W: usize> Div for Lanes<W> {
    type Output = Self;
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        let mut r = [0.0; W];
        for b in 0..W {
            r[b] = self.0[b] / o.0[b];
        }
        Lanes(r)
    }
}

impl<const W: usize> Neg for Lanes<W> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        let mut r = [0.0; W];
        for b in 0..W {
            r[b] = -self.0[b];
        }
        Lanes(r)
    }
}

impl<const W: usize> Real for Lanes<W> {
    // Lane sets (`nonfinite_lanes`, a bundle's running lanes) hold at most MAX_LANES.
    const LANES: usize = {
        assert!(
            W >= 1 && W <= MAX_LANES,
            "a bundle has 1 to MAX_LANES lanes"
        );
        W
    };
    #[inline(always)]
    fn splat(x: f64) -> Self {
        Lanes([x; W])
    }
    #[inline(always)]
    fn lane(&self, b: usize) -> f64 {
        self.0[b]
    }
    #[inline(always)]
    fn set_lane(&mut self, b: usize, x: f64) {
        self.0[b] = x;
    }
    #[inline(always)]
    fn keep_max(self, e: Self) -> Self {
        let mut r = [0.0; W];
        for b in 0..W {
            r[b] = if e.0[b] > self.0[b] {
                e.0[b]
            } else {
                self.0[b]
            };
        }
        Lanes(r)
    }
    #[inline(always)]
    fn keep_min(self, e: Self) -> Self {
        let mut r = [0.0; W];
        for b in 0..W {
            r[b] = if e.0[b] < self.0[b] {
                e.0[b]
            } else {
                self.0[b]
            };
        }
        Lanes(r)
    }
    #[inline(always)]
    fn nonfinite_lanes(self) -> LaneSet {
        let mut s = LaneSet::EMPTY;
        for b in 0..W {
            s.insert_if(b, self.0[b].to_bits() & EXPONENT == EXPONENT);
        }
        s
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        let mut r = [0.0; W];
        for b in 0..W {
            r[b] = self.0[b].sqrt();
        }
        Lanes(r)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        let mut r = [0.0; W];
        for b in 0..W {
            r[b] = self.0[b].abs();
        }
        Lanes(r)
    }
    #[inline(always)]
    fn map(self, f: fn(f64) -> f64) -> Self {
        let mut r = [0.0; W];
        for b in 0..W {
            r[b] = f(self.0[b]);
        }
        Lanes(r)
    }
    #[inline(always)]
    fn map2(self, other: Self, f: fn(f64, f64) -> f64) -> Self {
        let mut r = [0.0; W];
        for b in 0..W {
            r[b] = f(self.0[b], other.0[b]);
        }
        Lanes(r)
    }
    #[inline(always)]
    fn as_f64s(x: &[Self]) -> Option<&[f64]> {
        // SAFETY: Lanes is repr(C) over [f64; W]; without padding, n values are n·W doubles.
        (std::mem::size_of::<Self>() == 8 * W)
            .then(|| unsafe { std::slice::from_raw_parts(x.as_ptr().cast::<f64>(), x.len() * W) })
    }
    #[inline(always)]
    fn as_f64s_mut(x: &mut [Self]) -> Option<&mut [f64]> {
        // SAFETY: as above; the borrow is handed on.
        (std::mem::size_of::<Self>() == 8 * W).then(|| unsafe {
            std::slice::from_raw_parts_mut(x.as_mut_ptr().cast::<f64>(), x.len() * W)
        })
    }
}

/// Whether every entry of a slice of numbers is finite: an OR over exponent bits, which
/// vectorizes (a floating-point sum would be a sequential chain).
#[inline(always)]
pub fn all_finite<L: Real>(x: &[L]) -> bool {
    let mut bad = LaneSet::EMPTY;
    for &v in x {
        bad |= v.nonfinite_lanes();
    }
    bad.is_empty()
}

/// The first index of `x` where `ok` fails, for validating long rows: a pass without early
/// exits (chunks of 64 folded with `&`, which the compiler vectorizes), and the search for the
/// position only when that pass finds a failure.
#[inline]
pub fn first_failing(x: &[f64], ok: impl Fn(f64) -> bool + Copy) -> Option<usize> {
    if x.chunks(64)
        .all(|c| c.iter().fold(true, |all, &v| all & ok(v)))
    {
        None
    } else {
        x.iter().position(|&v| !ok(v))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_failing_finds_the_first_bad_entry_past_the_chunks() {
        let mut x = vec![1.0; 200];
        assert_eq!(first_failing(&x, f64::is_finite), None);
        x[130] = f64::NAN;
        x[199] = f64::INFINITY;
        assert_eq!(first_failing(&x, f64::is_finite), Some(130));
        x[3] = 0.0;
        assert_eq!(first_failing(&x, |v| v != 0.0), Some(3));
        assert_eq!(first_failing(&x[..3], |v| v != 0.0), None);
    }

    #[test]
    fn lanes_give_the_scalar_bits() {
        let a = Lanes([1.5, -2.0, 3.25, 1e-300, 0.1, 7.0, -0.0, 2.5]);
        let b = Lanes([0.3, 4.0, -1.0, 1e300, 0.7, 3.0, 1.0, 1.0 / 3.0]);
        let r = (a * b - a / b + (-a)) * a;
        for k in 0..8 {
            let (x, y) = (a.0[k], b.0[k]);
            assert_eq!(r.0[k].to_bits(), ((x * y - x / y + (-x)) * x).to_bits());
        }
        assert_eq!(a.map(f64::exp).0[2].to_bits(), 3.25f64.exp().to_bits());
    }

    #[test]
    fn extremes_ignore_nan_and_masks_find_it() {
        let hi = Lanes([1.0, 2.0]);
        let e = Lanes([f64::NAN, 3.0]);
        assert_eq!(hi.keep_max(e).0, [1.0, 3.0]);
        assert_eq!(e.nonfinite_lanes().iter().collect::<Vec<_>>(), [0]);
        assert_eq!(
            Lanes([1.0, f64::INFINITY])
                .nonfinite_lanes()
                .iter()
                .collect::<Vec<_>>(),
            [1]
        );
        assert!(!all_finite(&[1.0, f64::NAN]));
    }

    #[test]
    fn lane_sets_hold_every_lane_of_the_widest_bundle() {
        for count in [0, 1, 63, 64, 65, 200, 255, MAX_LANES] {
            let s = LaneSet::first(count);
            assert_eq!(s.iter().collect::<Vec<_>>(), (0..count).collect::<Vec<_>>());
        }
        let mut x = Lanes([1.0; MAX_LANES]);
        x.0[70] = f64::NAN;
        x.0[255] = f64::NEG_INFINITY;
        let bad = x.nonfinite_lanes();
        assert_eq!(bad.iter().collect::<Vec<_>>(), [70, 255]);
        let mut running = LaneSet::first(MAX_LANES);
        running.remove(70);
        assert_eq!((bad & running).iter().collect::<Vec<_>>(), [255]);
        assert!((bad & LaneSet::first(70)).is_empty());
    }
}

//! The libm shim: sin and cos of one argument in one call, for the interpreter and machine code.

use crate::real::Real;

#[cfg(all(target_os = "linux", target_env = "gnu"))]
extern "C" {
    /// glibc's sin and cos with one range reduction (`<math.h>`, GNU extension).
    fn sincos(x: f64, sin: *mut f64, cos: *mut f64);
}

/// [`sin_cos`] as the C ABI calls it, for machine code: sin x to `*sin`, cos x to `*cos`.
/// With glibc `sincos` itself (no wrapper between the compiled code and libm).
#[cfg(all(target_os = "linux", target_env = "gnu"))]
pub const SIN_COS_C: unsafe extern "C" fn(f64, *mut f64, *mut f64) = sincos;

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
pub const SIN_COS_C: unsafe extern "C" fn(f64, *mut f64, *mut f64) = {
    unsafe extern "C" fn two_calls(x: f64, sin: *mut f64, cos: *mut f64) {
        // SAFETY: the caller passes two valid doubles to write.
        unsafe {
            *sin = x.sin();
            *cos = x.cos();
        }
    }
    two_calls
};

/// (sin x, cos x) through [`SIN_COS_C`]. With glibc one `sincos` call, whose results are bit
/// for bit those of `sin` and `cos` (the same kernels after the same reduction; tested on 2·10⁸
/// arguments across the whole double range, and in this crate's tests), so a code that merges
/// the two calls and one that does not compute the same bits. Elsewhere the two calls.
#[inline]
pub fn sin_cos(x: f64) -> (f64, f64) {
    let (mut s, mut c) = (0.0, 0.0);
    // SAFETY: SIN_COS_C writes one double through each pointer, both valid locals.
    unsafe { SIN_COS_C(x, &mut s, &mut c) };
    (s, c)
}

/// [`sin_cos`] lane by lane.
#[inline(always)]
pub(super) fn sin_cos_lanes<L: Real>(x: L) -> (L, L) {
    let (mut sin, mut cos) = (x, x);
    for j in 0..L::LANES {
        let (s, c) = sin_cos(x.lane(j));
        sin.set_lane(j, s);
        cos.set_lane(j, c);
    }
    (sin, cos)
}

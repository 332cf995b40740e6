//! Runs a kernel in the copy compiled for the widest vectors this CPU has, written once.
//!
//! Only tight loops are copied (each copy a small function): the orchestration around them is
//! compiled once. The copies differ only in instruction encoding: Rust never contracts a·b + c
//! into a fused multiply-add, so every copy gives the same bits.

/// A loop worth compiling per instruction set.
pub trait Kernel {
    type Output;
    /// Worth more than one copy at all.
    const WIDE: bool = true;
    /// Worth an AVX2 copy besides the AVX-512 one (not for one-lane compile-time shapes, which
    /// gain only AVX-512's 32 registers).
    const AVX2: bool = true;
    /// The loop; `#[inline(always)]`, so that each copy below compiles it for its features.
    fn run(&mut self) -> Self::Output;
}

/// `k.run()` in the best copy for this CPU.
#[inline(always)]
pub fn run<K: Kernel>(k: &mut K) -> K::Output {
    #[cfg(target_arch = "x86_64")]
    if K::WIDE {
        if std::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU supports AVX-512F, checked just above.
            return unsafe { run_avx512(k) };
        }
        if K::AVX2 && std::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            return unsafe { run_avx2(k) };
        }
    }
    run_baseline(k)
}

#[inline(never)]
fn run_baseline<K: Kernel>(k: &mut K) -> K::Output {
    k.run()
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline(never)]
unsafe fn run_avx512<K: Kernel>(k: &mut K) -> K::Output {
    k.run()
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline(never)]
unsafe fn run_avx2<K: Kernel>(k: &mut K) -> K::Output {
    k.run()
}

/// `f()` in the best copy for this CPU: a loop over long vectors written as a closure (the
/// Krylov path's products and sums). The closure is inlined into each copy, so it is compiled for
/// that copy's vectors; the same bits in every copy, as for any [`Kernel`].
#[inline(always)]
pub fn wide<R, F: FnMut() -> R>(f: F) -> R {
    struct Closure<F>(F);
    impl<R, F: FnMut() -> R> Kernel for Closure<F> {
        type Output = R;
        #[inline(always)]
        fn run(&mut self) -> R {
            (self.0)()
        }
    }
    run(&mut Closure(f))
}

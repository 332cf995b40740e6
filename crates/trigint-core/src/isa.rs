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
    /// Worth an AVX2 copy besides the AVX-512 one.
    const AVX2: bool = true;
    /// Worth an AVX-512 copy besides the AVX2 one; when false, a CPU with AVX-512 runs the AVX2
    /// copy (each copy is a whole optimized function to build).
    const AVX512: bool = true;
    /// The loop; `#[inline(always)]`, so that each copy below compiles it for its features.
    fn run(&mut self) -> Self::Output;
    /// The loop in the copy whose vector registers hold `vector_bytes` bytes (64 for AVX-512,
    /// 32 for AVX2, 16 for the baseline), a constant in each copy: for loops that cut their
    /// work to the registers they have. The same bits whatever the value.
    #[inline(always)]
    fn run_for(&mut self, vector_bytes: usize) -> Self::Output {
        let _ = vector_bytes;
        self.run()
    }
}

/// The instruction sets the kernels may use here: the CPU's, capped by the environment
/// variable `TRIGINT_ISA` (`avx512`, `avx2` or `baseline`; read once), which lets one machine
/// time the copies another machine would run. Every copy gives the same bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Allowed {
    pub avx512: bool,
    pub avx2: bool,
}

/// See [`Allowed`].
pub fn allowed() -> Allowed {
    static ALLOWED: std::sync::OnceLock<Allowed> = std::sync::OnceLock::new();
    *ALLOWED.get_or_init(|| {
        #[cfg(target_arch = "x86_64")]
        let (avx512, avx2) = (
            std::is_x86_feature_detected!("avx512f"),
            std::is_x86_feature_detected!("avx2"),
        );
        #[cfg(not(target_arch = "x86_64"))]
        let (avx512, avx2) = (false, false);
        let cap = std::env::var("TRIGINT_ISA").unwrap_or_default();
        match cap.trim().to_ascii_lowercase().as_str() {
            "avx2" => Allowed {
                avx512: false,
                avx2,
            },
            "baseline" | "sse2" => Allowed {
                avx512: false,
                avx2: false,
            },
            _ => Allowed { avx512, avx2 },
        }
    })
}

/// `k.run()` in the best copy for this CPU (see [`allowed`]).
#[inline(always)]
pub fn run<K: Kernel>(k: &mut K) -> K::Output {
    #[cfg(target_arch = "x86_64")]
    if K::WIDE {
        let isa = allowed();
        if K::AVX512 && isa.avx512 {
            // SAFETY: the CPU supports AVX-512F (`allowed` checked it).
            return unsafe { run_avx512(k) };
        }
        if K::AVX2 && isa.avx2 {
            // SAFETY: the CPU supports AVX2 (`allowed` checked it).
            return unsafe { run_avx2(k) };
        }
    }
    run_baseline(k)
}

#[inline(never)]
fn run_baseline<K: Kernel>(k: &mut K) -> K::Output {
    k.run_for(16)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline(never)]
unsafe fn run_avx512<K: Kernel>(k: &mut K) -> K::Output {
    k.run_for(64)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline(never)]
unsafe fn run_avx2<K: Kernel>(k: &mut K) -> K::Output {
    k.run_for(32)
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

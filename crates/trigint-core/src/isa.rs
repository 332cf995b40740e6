//! Runs a kernel in one of the copies compiled per instruction set, written once.
//!
//! Only tight loops are copied (each copy a small function): the orchestration around them is
//! compiled once. The copies differ only in instruction encoding: Rust never contracts a·b + c
//! into a fused multiply-add, so every copy gives the same bits. Which copy runs a stepping
//! loop is the [planner](crate::plan)'s choice, measured per machine; other loops run the widest.

use crate::plan::{self, Isa, Mode};

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
    /// A stepping loop that the planner chooses a copy for (see [`steps`](Self::steps)); a
    /// constant, so that other loops compile no measuring code.
    const PLANNED: bool = false;
    /// A stepping loop's steps n..e, which the planner may run in pieces, each in its own copy
    /// (a piece's end is one more finiteness test: the same bits). None: never planned.
    fn steps(&self) -> Option<(u64, u64)> {
        None
    }
    /// Narrows the loop to steps n..e (see [`steps`](Self::steps)).
    fn set_steps(&mut self, n: u64, e: u64) {
        let _ = (n, e);
    }
    /// The number of coordinates: loops are planned per size class (powers of two).
    fn size(&self) -> usize {
        0
    }
    /// Whether a piece's output ends the loop before its last step (a blow-up found, an error).
    fn stops_early(out: &Self::Output) -> bool {
        let _ = out;
        false
    }
}

/// The instruction sets the kernels may use here: the CPU's (in an optimized build), capped by
/// the environment variable `TRIGINT_ISA` (`avx512`, `avx2` or `baseline`; read once), which
/// lets one machine time the copies another machine would run. Every copy gives the same bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Allowed {
    pub avx512: bool,
    pub avx2: bool,
}

/// See [`Allowed`]. The AVX-512 copies use its VL and DQ parts too (every AVX-512 CPU but the
/// Xeon Phi has them): with VL, scalar and 128/256-bit code on registers xmm16–31 needs no
/// 512-bit moves.
pub fn allowed() -> Allowed {
    static ALLOWED: std::sync::OnceLock<Allowed> = std::sync::OnceLock::new();
    *ALLOWED.get_or_init(|| {
        let has = crate::cpu::features();
        // (a debug build has the baseline copy alone: see `WIDE_COPIES`)
        let avx512 = WIDE_COPIES
            && ["avx512f", "avx512vl", "avx512dq"]
                .iter()
                .all(|f| has.contains(f));
        let avx2 = WIDE_COPIES && has.contains(&"avx2");
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

/// Whether the AVX2 and AVX-512 copies are compiled at all: on x86-64, in optimized builds. A
/// debug build (the Rust tests') compiles the baseline copy alone: the copies differ only in
/// instruction encoding, their equality is tested on the release build
/// (`tests/test_isa_copies.py`), and three debug copies of every kernel were most of the test
/// build's time.
const WIDE_COPIES: bool = cfg!(all(target_arch = "x86_64", not(debug_assertions)));

/// Whether the CPU is AMD's (read once).
fn amd() -> bool {
    static AMD: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *AMD.get_or_init(crate::cpu::is_amd)
}

/// The copies of a kernel (with constants `WIDE`, `AVX512`, `AVX2`) this CPU may run, widest
/// first. Not generic: one function for every kernel.
fn copies(wide: bool, avx512: bool, avx2: bool) -> ([Isa; 3], usize) {
    let isa = allowed();
    let mut out = [Isa::Baseline; 3];
    let mut n = 0;
    if wide && WIDE_COPIES {
        if avx512 && isa.avx512 {
            out[n] = Isa::Avx512;
            n += 1;
        }
        if avx2 && isa.avx2 {
            out[n] = Isa::Avx2;
            n += 1;
        }
    }
    out[n] = Isa::Baseline;
    (out, n + 1)
}

/// `k.run()` in the copy for this CPU: the planner's choice for a stepping loop, else the widest.
#[inline(always)]
pub fn run<K: Kernel>(k: &mut K) -> K::Output {
    let (all, n) = copies(K::WIDE, K::AVX512, K::AVX2);
    // Where there is a VEX-encoded copy (AVX2, AVX-512), the planner chooses among those alone,
    // except on AMD's CPUs. The baseline copy's legacy-SSE instructions ran the one-trajectory
    // tangent loop at 29-31 or at 53-60 ns per FPU step between processes on an Intel Xeon
    // (model 207), the same instructions; likely Intel's SSE/AVX transition cost, paid when AVX
    // code that ran before in the process (glibc's AVX-512 memmove, NumPy's kernels, ours) left
    // upper register halves dirty. The VEX-encoded copies do not pay it, nor do AMD's cores,
    // where the baseline copy can be the fastest: one FPU trajectory with its energies
    // streamed, 19.5 ns per step against 24.6 for the AVX2 copy on an AMD EPYC (Zen 3).
    let candidates = if amd() {
        &all[..n]
    } else {
        &all[..n.saturating_sub(1).max(1)]
    };
    if K::PLANNED && candidates.len() > 1 && plan::mode() == Mode::Measure {
        if let Some((first, end)) = k.steps().filter(|(n, e)| e > n) {
            // (A loop of no steps has nothing to time.)
            let id = plan::Id::of::<K>(k.size());
            if let Some(isa) = plan::chosen(id) {
                return run_copy(k, isa);
            }
            return run_measuring(k, id, candidates, first, end);
        }
    }
    run_copy(k, all[0])
}

/// Steps first..end in pieces, each timed in the copy the planner asks for, until it has chosen.
#[inline(never)]
fn run_measuring<K: Kernel>(
    k: &mut K,
    id: plan::Id,
    copies: &[Isa],
    first: u64,
    end: u64,
) -> K::Output {
    let mut n = first;
    loop {
        match plan::next(id, copies) {
            plan::Next::Use(isa) => {
                k.set_steps(n, end);
                return run_copy(k, isa);
            }
            plan::Next::Measure(isa, steps) => {
                let e = n.saturating_add(steps).min(end);
                k.set_steps(n, e);
                let clock = std::time::Instant::now();
                let out = run_copy(k, isa);
                let ns = clock.elapsed().as_nanos() as f64;
                plan::record(id, isa, copies, ns, e - n);
                if e >= end || K::stops_early(&out) {
                    return out;
                }
                n = e;
            }
        }
    }
}

#[inline(always)]
fn run_copy<K: Kernel>(k: &mut K, isa: Isa) -> K::Output {
    // The conditions on the kernel's constants come first, so that a copy it does not want is
    // never compiled (the build-time cut of compiled programs and waves: no AVX-512 copy).
    #[cfg(all(target_arch = "x86_64", not(debug_assertions)))]
    if K::WIDE {
        if K::AVX512 && isa == Isa::Avx512 {
            // SAFETY: `copies` lists a copy only where `allowed` found its features.
            return unsafe { avx512_copy::run(k) };
        }
        if K::AVX2 && isa == Isa::Avx2 {
            // SAFETY: as above.
            return unsafe { avx2_copy::run(k) };
        }
    }
    let _ = isa;
    baseline_copy::run(k)
}

// One module per copy. rustc places a generic function's instances in the code-generation unit
// of the module that defines it, and LLVM optimizes a unit on one thread: with the three copies
// in one module, every kernel of every copy (most of the binding's machine code) was one unit,
// and the release build ran on one core for minutes. A module each lets the copies build in
// parallel; the code in them is the same.

mod baseline_copy {
    use super::Kernel;

    #[inline(never)]
    pub(super) fn run<K: Kernel>(k: &mut K) -> K::Output {
        k.run_for(16)
    }
}

#[cfg(all(target_arch = "x86_64", not(debug_assertions)))]
mod avx512_copy {
    use super::Kernel;

    #[target_feature(enable = "avx512f,avx512vl,avx512dq")]
    #[inline(never)]
    pub(super) unsafe fn run<K: Kernel>(k: &mut K) -> K::Output {
        k.run_for(64)
    }
}

#[cfg(all(target_arch = "x86_64", not(debug_assertions)))]
mod avx2_copy {
    use super::Kernel;

    #[target_feature(enable = "avx2")]
    #[inline(never)]
    pub(super) unsafe fn run<K: Kernel>(k: &mut K) -> K::Output {
        k.run_for(32)
    }
}

/// `f()` in the widest copy for this CPU: a loop over long vectors written as a closure (the
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

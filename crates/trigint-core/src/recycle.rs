//! [`Recycling`]: the system allocator, with the big blocks a call frees kept for the next call
//! that asks for the same size.
//!
//! Why: a call on a 2¹⁶-point wave allocates about forty buffers of 512 KiB (the method's rows,
//! the state, the FFT scratch, the samples) and frees them at its end. glibc serves such blocks
//! with `mmap` or from the top of the heap, and gives them back to the kernel on free, so every
//! call pays a page fault per 4 KiB again: 10 of the 31 ms a 2-step call took on an Intel Xeon
//! (model 207). Calls on one problem ask for the same sizes every time; kept here, the next call
//! finds its blocks already mapped.
//!
//! Only blocks of at least [`SMALLEST`] bytes are kept, at most [`SLOTS`] of them and
//! [`KEPT_BYTES`] in all; the oldest go back to the system first. A kept block is handed out
//! only for exactly its size and alignment. The extension module installs it as its
//! `#[global_allocator]`.
//!
//! Every block of at least [`LINE_ALIGNED_FROM`] bytes also starts on a cache line ([`LINE`]
//! bytes). Why: glibc aligns to 16 bytes, so the rows of a run-time shape's state (`Vec<f64>`)
//! started anywhere in a cache line, and every 64-byte vector load and store of the AVX-512
//! copies then touched two lines. FPU m = 1000, one trajectory (AMD Zen 5, alternated
//! processes): 761–775 → 478–495 ns a step without energies, 962–1034 → 682–686 ns with them.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::Mutex;

/// Blocks smaller than this go straight to the system (its own free lists serve them well).
pub const SMALLEST: usize = 128 << 10;
/// At most this many blocks are kept.
pub const SLOTS: usize = 64;
/// At most this many bytes are kept.
pub const KEPT_BYTES: usize = 256 << 20;
/// A cache line: where the blocks of at least [`LINE_ALIGNED_FROM`] bytes start.
pub const LINE: usize = 64;
/// Blocks this large or larger start on a cache line (smaller ones hold no long rows).
pub const LINE_ALIGNED_FROM: usize = 512;

/// The layout a block is allocated with: `layout`, on a cache line if the block is large.
#[inline]
fn lined(layout: Layout) -> Layout {
    if layout.size() >= LINE_ALIGNED_FROM && layout.align() < LINE {
        // SAFETY: LINE is a power of two, and a size that fit `layout` fits it rounded up to
        // LINE (sizes near isize::MAX are refused before they reach an allocator).
        unsafe { Layout::from_size_align_unchecked(layout.size(), LINE) }
    } else {
        layout
    }
}

/// A kept block: its address, size and alignment (an address, not a pointer, so that the pool
/// can live in a static).
#[derive(Clone, Copy)]
struct Block {
    address: usize,
    size: usize,
    align: usize,
}

/// The kept blocks, oldest first. A fixed array: the pool must never allocate, since it runs
/// inside the allocator.
struct Pool {
    blocks: [Block; SLOTS],
    len: usize,
    bytes: usize,
}

impl Pool {
    const fn new() -> Self {
        Pool {
            blocks: [Block {
                address: 0,
                size: 0,
                align: 0,
            }; SLOTS],
            len: 0,
            bytes: 0,
        }
    }

    /// The newest kept block of this layout, taken out of the pool.
    fn take(&mut self, layout: Layout) -> Option<*mut u8> {
        let i = (0..self.len).rev().find(|&i| {
            let b = self.blocks[i];
            b.size == layout.size() && b.align == layout.align()
        })?;
        let b = self.blocks[i];
        self.blocks.copy_within(i + 1..self.len, i);
        self.len -= 1;
        self.bytes -= b.size;
        Some(b.address as *mut u8)
    }

    /// Keeps a block; returns the blocks that no longer fit (the oldest first), for the caller
    /// to free. A block larger than the whole budget is not kept: it is returned itself.
    fn keep(&mut self, block: Block) -> ([Option<Block>; SLOTS], usize) {
        let mut evicted = [None; SLOTS];
        let mut n = 0;
        if block.size > KEPT_BYTES {
            evicted[0] = Some(block);
            return (evicted, 1);
        }
        while self.len == SLOTS || self.bytes + block.size > KEPT_BYTES {
            let oldest = self.blocks[0];
            self.blocks.copy_within(1..self.len, 0);
            self.len -= 1;
            self.bytes -= oldest.size;
            evicted[n] = Some(oldest);
            n += 1;
        }
        self.blocks[self.len] = block;
        self.len += 1;
        self.bytes += block.size;
        (evicted, n)
    }
}

/// The system allocator with big freed blocks kept for reuse (see the module's text).
pub struct Recycling {
    pool: Mutex<Pool>,
}

impl Recycling {
    pub const fn new() -> Self {
        Recycling {
            pool: Mutex::new(Pool::new()),
        }
    }

    fn pool(&self) -> std::sync::MutexGuard<'_, Pool> {
        // A panic never happens while the lock is held (the pool's code has none), but a
        // poisoned lock must not make every later allocation panic.
        self.pool.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Bytes kept now.
    pub fn kept_bytes(&self) -> usize {
        self.pool().bytes
    }
}

impl Drop for Recycling {
    fn drop(&mut self) {
        let pool = self.pool.get_mut().unwrap_or_else(|e| e.into_inner());
        for b in &pool.blocks[..pool.len] {
            // SAFETY: a kept block is a System block of this layout that nobody else holds.
            unsafe {
                System.dealloc(
                    b.address as *mut u8,
                    Layout::from_size_align_unchecked(b.size, b.align),
                )
            };
        }
        pool.len = 0;
        pool.bytes = 0;
    }
}

impl Default for Recycling {
    fn default() -> Self {
        Recycling::new()
    }
}

// SAFETY: every block handed out is a `System` block of the requested layout on a cache line
// when large (`lined`; either fresh or kept after a `dealloc` with that layout), and every block
// given back goes either to the pool or to `System` with the layout it was allocated with.
unsafe impl GlobalAlloc for Recycling {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let layout = lined(layout);
        if layout.size() >= SMALLEST {
            if let Some(p) = self.pool().take(layout) {
                return p;
            }
        }
        System.alloc(layout)
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        let layout = lined(layout);
        if layout.size() >= SMALLEST {
            if let Some(p) = self.pool().take(layout) {
                std::ptr::write_bytes(p, 0, layout.size());
                return p;
            }
        }
        System.alloc_zeroed(layout)
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        let layout = lined(layout);
        if layout.size() < SMALLEST {
            return System.dealloc(ptr, layout);
        }
        let block = Block {
            address: ptr as usize,
            size: layout.size(),
            align: layout.align(),
        };
        let (evicted, n) = self.pool().keep(block);
        // freed outside the lock
        for b in evicted.iter().take(n).flatten() {
            System.dealloc(
                b.address as *mut u8,
                Layout::from_size_align_unchecked(b.size, b.align),
            );
        }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let (old, new) = (
            lined(layout),
            lined(Layout::from_size_align_unchecked(new_size, layout.align())),
        );
        if old.align() == new.align() {
            // a System block of `old`, kept or not
            return System.realloc(ptr, old, new_size);
        }
        // Grown past LINE_ALIGNED_FROM (or shrunk below it): a new block of the new alignment.
        let fresh = self.alloc(Layout::from_size_align_unchecked(new_size, layout.align()));
        if !fresh.is_null() {
            std::ptr::copy_nonoverlapping(ptr, fresh, layout.size().min(new_size));
            self.dealloc(ptr, layout);
        }
        fresh
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn layout(size: usize) -> Layout {
        Layout::from_size_align(size, 8).unwrap()
    }

    #[test]
    fn a_freed_big_block_is_handed_out_again_for_its_size_only() {
        let r = Recycling::new();
        unsafe {
            let a = r.alloc(layout(SMALLEST));
            a.write(7);
            r.dealloc(a, layout(SMALLEST));
            assert_eq!(r.kept_bytes(), SMALLEST);
            // another size does not take it
            let b = r.alloc(layout(SMALLEST + 8));
            assert_ne!(a, b);
            assert_eq!(r.kept_bytes(), SMALLEST);
            // the same size does, zeroed when asked
            let c = r.alloc_zeroed(layout(SMALLEST));
            assert_eq!(c, a);
            assert!(std::slice::from_raw_parts(c, SMALLEST)
                .iter()
                .all(|&x| x == 0));
            assert_eq!(r.kept_bytes(), 0);
            r.dealloc(b, layout(SMALLEST + 8));
            r.dealloc(c, layout(SMALLEST));
            assert_eq!(r.kept_bytes(), 2 * SMALLEST + 8);
        }
    }

    #[test]
    fn large_blocks_start_on_a_cache_line_also_when_grown_to_it() {
        let r = Recycling::new();
        unsafe {
            for size in [LINE_ALIGNED_FROM, 4096 + 8, SMALLEST + 8] {
                let blocks: Vec<*mut u8> = (0..8).map(|_| r.alloc(layout(size))).collect();
                assert!(
                    blocks.iter().all(|&p| (p as usize).is_multiple_of(LINE)),
                    "size {size}"
                );
                for p in blocks {
                    r.dealloc(p, layout(size));
                }
            }
            // grown from a small block to a large one: moved to a line, its bytes kept
            let small = r.alloc(layout(24));
            small.copy_from(b"twenty-four bytes here..".as_ptr(), 24);
            let grown = r.realloc(small, layout(24), 4096);
            assert!((grown as usize).is_multiple_of(LINE));
            assert_eq!(
                std::slice::from_raw_parts(grown, 24),
                b"twenty-four bytes here.."
            );
            let more = r.realloc(grown, layout(4096), 8192);
            assert!((more as usize).is_multiple_of(LINE));
            assert_eq!(
                std::slice::from_raw_parts(more, 24),
                b"twenty-four bytes here.."
            );
            let shrunk = r.realloc(more, layout(8192), 16);
            assert_eq!(std::slice::from_raw_parts(shrunk, 16), b"twenty-four byte");
            r.dealloc(shrunk, layout(16));
        }
    }

    #[test]
    fn small_blocks_are_not_kept_and_the_budget_evicts_the_oldest() {
        let r = Recycling::new();
        unsafe {
            let s = r.alloc(layout(64));
            r.dealloc(s, layout(64));
            assert_eq!(r.kept_bytes(), 0);
            let big = KEPT_BYTES / 4;
            let blocks: Vec<*mut u8> = (0..5).map(|_| r.alloc(layout(big))).collect();
            for &p in &blocks {
                r.dealloc(p, layout(big));
            }
            // four fit; the first freed went back to the system
            assert_eq!(r.kept_bytes(), KEPT_BYTES);
            let again: Vec<*mut u8> = (0..4).map(|_| r.alloc(layout(big))).collect();
            for p in &blocks[1..] {
                assert!(again.contains(p));
            }
            assert_eq!(r.kept_bytes(), 0);
            for &p in &again {
                r.dealloc(p, layout(big));
            }
            // more slots than SLOTS: the count is capped too
            let many: Vec<*mut u8> = (0..SLOTS + 3).map(|_| r.alloc(layout(SMALLEST))).collect();
            for &p in &many {
                r.dealloc(p, layout(SMALLEST));
            }
            let pool = r.pool();
            assert_eq!(pool.len, SLOTS);
            assert!(pool.bytes <= KEPT_BYTES);
        }
    }
}

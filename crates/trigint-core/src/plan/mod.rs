//! The planner: which instruction-set copy of a stepping loop runs, chosen by the clock, as
//! FFTW's planner chooses among algorithms.
//!
//! Every copy gives the same bits (the ISA-copies tests), so the choice is free. The first time a
//! loop (a kernel type, with its compile-time constants, and a size class of its coordinates)
//! runs on a machine, its steps are cut into pieces that the copies the CPU has run in turn,
//! timed, until each copy has [`SAMPLES`] pieces of at least [`SAMPLE_NS`]; the widest copy within
//! [`MARGIN`] of the fastest runs from then on (a narrower one only where it is clearly faster:
//! closer, the difference is the clock's noise) and is remembered in the user's cache directory,
//! per CPU model and core version, stamped with the core's build. The
//! measuring takes a few milliseconds, once per machine. Cutting the steps into pieces only adds
//! finiteness tests inside the tight loop: the same bits.
//!
//! `TRIGINT_PLAN=estimate` measures nothing (the widest copy runs, the choice before plans);
//! `TRIGINT_ISA` fixes the copy. A plan cache that cannot be read or written is passed over with a
//! one-line note on standard error, never an error.

use std::cell::Cell;
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::{Mutex, OnceLock};

mod cache;
use cache::read_cache;
pub use cache::{build_id, cache_path};

/// Pieces timed per copy before choosing.
pub const SAMPLES: u32 = 3;
/// The least time (ns) one timed sample covers; shorter pieces are added up until it does.
pub const SAMPLE_NS: f64 = 150_000.0;
/// A narrower copy is chosen over a wider one only when it is faster by more than this fraction.
/// Why: the samples of a large kernel are a step or two each, and two copies within a few percent
/// of each other came out either way (a 2¹⁶-point wave step: the baseline copy chosen at 1.68
/// against 1.71 ms, though the AVX2 copy then ran it 10-20% faster; AMD Zen 3).
pub const MARGIN: f64 = 0.05;

/// An instruction-set copy of a kernel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Isa {
    Baseline,
    Avx2,
    Avx512,
}

impl Isa {
    pub const ALL: [Isa; 3] = [Isa::Baseline, Isa::Avx2, Isa::Avx512];

    pub fn name(self) -> &'static str {
        match self {
            Isa::Baseline => "baseline",
            Isa::Avx2 => "avx2",
            Isa::Avx512 => "avx512",
        }
    }

    fn parse(s: &str) -> Option<Isa> {
        Isa::ALL.into_iter().find(|i| i.name() == s)
    }

    fn index(self) -> usize {
        self as usize
    }
}

/// How copies are chosen (`TRIGINT_PLAN`, and `TRIGINT_ISA`, which fixes the copy).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Measured once per machine and loop, then cached (the default).
    Measure,
    /// The widest copy the CPU has, nothing measured.
    Estimate,
    /// `TRIGINT_ISA` set: the widest copy under that cap, nothing measured.
    Fixed,
}

impl Mode {
    pub fn name(self) -> &'static str {
        match self {
            Mode::Measure => "measure",
            Mode::Estimate => "estimate",
            Mode::Fixed => "fixed by TRIGINT_ISA",
        }
    }
}

/// The mode in force (environment read once).
pub fn mode() -> Mode {
    static MODE: OnceLock<Mode> = OnceLock::new();
    *MODE.get_or_init(|| {
        if !std::env::var("TRIGINT_ISA")
            .unwrap_or_default()
            .trim()
            .is_empty()
        {
            return Mode::Fixed;
        }
        match std::env::var("TRIGINT_PLAN")
            .unwrap_or_default()
            .trim()
            .to_ascii_lowercase()
            .as_str()
        {
            "estimate" => Mode::Estimate,
            "" | "measure" => Mode::Measure,
            other => {
                note(&format!(
                    "TRIGINT_PLAN={other:?} is not 'measure' or 'estimate'; measuring"
                ));
                Mode::Measure
            }
        }
    })
}

/// One line on standard error, prefixed with the library's name.
fn note(text: &str) {
    eprintln!("trigint: {text}");
}

/// A loop to plan: its kernel type and its size class. Compared by the address of the type's
/// name (unique per compiled type), so that a lookup never compares the long name itself.
///
/// The type enters only here: everything after `Id::of` is one function for every kernel, not an
/// instance per kernel type (those were a seventh of the binding's code to optimize).
#[derive(Debug, Clone, Copy)]
pub struct Id {
    type_name: &'static str,
    size_class: u32,
}

impl Id {
    #[inline(always)]
    pub fn of<K: ?Sized>(n_coordinates: usize) -> Id {
        Id {
            type_name: std::any::type_name::<K>(),
            size_class: usize::BITS - n_coordinates.saturating_sub(1).leading_zeros(),
        }
    }

    fn address(&self) -> usize {
        self.type_name.as_ptr() as usize
    }
}

impl PartialEq for Id {
    fn eq(&self, other: &Id) -> bool {
        self.address() == other.address() && self.size_class == other.size_class
    }
}

impl Eq for Id {}

impl std::hash::Hash for Id {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.address().hash(state);
        self.size_class.hash(state);
    }
}

/// The key of a loop in the cache: its type without module paths, and the size class.
fn key_text(id: Id) -> String {
    let full = id.type_name;
    let mut short = String::with_capacity(full.len());
    let mut word = String::new();
    let mut chars = full.chars().peekable();
    while let Some(c) = chars.next() {
        if c == ':' && chars.peek() == Some(&':') {
            chars.next();
            word.clear();
            continue;
        }
        if c.is_alphanumeric() || c == '_' {
            word.push(c);
        } else {
            short.push_str(&word);
            word.clear();
            short.push(c);
        }
    }
    short.push_str(&word);
    format!("{short} n<=2^{}", id.size_class)
}

/// A loop's plan: chosen, or being measured.
struct Entry {
    key: String,
    chosen: Option<Isa>,
    /// The best ns per step of each copy so far (indexed by `Isa as usize`; infinite: none yet).
    best: [f64; 3],
    samples: [u32; 3],
    /// The copy now timed and what its pieces add up to (ns, steps).
    current: usize,
    pending: (f64, u64),
}

struct Planner {
    cache: Option<PathBuf>,
    /// Plans read from the cache (key → copy, timings as written).
    known: HashMap<String, (Isa, String)>,
    entries: HashMap<Id, Entry>,
    write_failed: bool,
}

fn planner() -> &'static Mutex<Planner> {
    static PLANNER: OnceLock<Mutex<Planner>> = OnceLock::new();
    PLANNER.get_or_init(|| {
        // Unit tests measure made-up loops: never into the user's cache.
        let cache = if cfg!(test) { None } else { cache_path() };
        let known = cache.as_ref().map(read_cache).unwrap_or_default();
        Mutex::new(Planner {
            cache,
            known,
            entries: HashMap::new(),
            write_failed: false,
        })
    })
}

fn lock() -> std::sync::MutexGuard<'static, Planner> {
    // A panic while the planner was held leaves plain data: still usable.
    planner().lock().unwrap_or_else(|p| p.into_inner())
}

thread_local! {
    /// The last plan this thread looked up (a run asks once per segment).
    static LAST: Cell<Option<(Id, Isa)>> = const { Cell::new(None) };
}

/// What to run next.
pub enum Next {
    /// The chosen copy, for all the remaining steps.
    Use(Isa),
    /// Time this copy on at most this many steps.
    Measure(Isa, u64),
}

/// The copy chosen for `id` if there is one (no lock once this thread has seen it).
pub fn chosen(id: Id) -> Option<Isa> {
    if let Some((last, isa)) = LAST.get() {
        if last == id {
            return Some(isa);
        }
    }
    let isa = lock().entries.get(&id).and_then(|e| e.chosen)?;
    LAST.set(Some((id, isa)));
    Some(isa)
}

/// The next piece of loop `id`, given the copies this CPU may run.
pub fn next(id: Id, copies: &[Isa]) -> Next {
    let mut guard = lock();
    let p = &mut *guard;
    let entry = p.entries.entry(id).or_insert_with(|| {
        let key = key_text(id);
        let chosen = p
            .known
            .get(&key)
            .filter(|(_, timings)| measured_all(timings, copies))
            .map(|(isa, _)| *isa)
            .filter(|isa| copies.contains(isa));
        Entry {
            key,
            chosen,
            best: [f64::INFINITY; 3],
            samples: [0; 3],
            current: 0,
            pending: (0.0, 0),
        }
    });
    if let Some(isa) = entry.chosen {
        return Next::Use(isa);
    }
    let isa = copies[entry.current % copies.len()];
    // Pieces sized to one sample from the fastest copy seen so far (a few steps at first).
    let per_step = entry.best.iter().copied().fold(f64::INFINITY, f64::min);
    let steps = if per_step.is_finite() && per_step > 0.0 {
        ((SAMPLE_NS - entry.pending.0).max(0.0) / per_step).ceil() as u64
    } else {
        4
    };
    Next::Measure(isa, steps.clamp(1, 1 << 20))
}

/// Whether a cached plan's timings ("avx2=… baseline=…") cover every copy now a candidate: a
/// build that gives a loop a copy more (chains their AVX-512 copy) measures it again, rather
/// than keep a choice made without it.
fn measured_all(timings: &str, copies: &[Isa]) -> bool {
    copies.iter().all(|c| {
        timings
            .split_whitespace()
            .any(|t| t.split('=').next() == Some(c.name()))
    })
}

/// Adds a timed piece (`ns` for `steps` steps in copy `isa`) to loop `id`'s measuring; chooses
/// once every copy has its samples.
pub fn record(id: Id, isa: Isa, copies: &[Isa], ns: f64, steps: u64) {
    let mut guard = lock();
    let p = &mut *guard;
    let Some(entry) = p.entries.get_mut(&id) else {
        return;
    };
    if steps == 0 || entry.chosen.is_some() || copies[entry.current % copies.len()] != isa {
        return; // (a piece of no steps times only the call)
    }
    entry.pending.0 += ns;
    entry.pending.1 += steps;
    let i = isa.index();
    if entry.pending.1 > 0 {
        // Before a sample completes, its rate sizes the next pieces.
        let rate = entry.pending.0 / entry.pending.1 as f64;
        if entry.samples[i] == 0 && entry.best[i].is_infinite() {
            entry.best[i] = rate;
        }
    }
    if entry.pending.0 < SAMPLE_NS {
        return;
    }
    let rate = entry.pending.0 / entry.pending.1 as f64;
    entry.best[i] = if entry.samples[i] == 0 {
        rate
    } else {
        entry.best[i].min(rate)
    };
    entry.samples[i] += 1;
    entry.pending = (0.0, 0);
    entry.current += 1;
    if copies.iter().all(|c| entry.samples[c.index()] >= SAMPLES) {
        let fastest = copies
            .iter()
            .map(|c| entry.best[c.index()])
            .fold(f64::INFINITY, f64::min);
        // `copies` lists the widest first
        let chosen = copies
            .iter()
            .copied()
            .find(|c| entry.best[c.index()] <= fastest * (1.0 + MARGIN))
            .unwrap_or(copies[0]);
        entry.chosen = Some(chosen);
        let timings = copies
            .iter()
            .map(|c| format!("{}={:.4}", c.name(), entry.best[c.index()]))
            .collect::<Vec<_>>()
            .join(" ");
        p.known.insert(entry.key.clone(), (chosen, timings));
        p.write_cache();
    }
}

/// A plan as [`report`] lists it.
#[derive(Debug, Clone)]
pub struct PlanRow {
    pub key: String,
    pub chosen: Option<&'static str>,
    /// "copy=ns per step …" as measured (empty while measuring)
    pub timings: String,
}

/// The plans known to this process: read from the cache or measured here.
pub fn report() -> Vec<PlanRow> {
    let p = lock();
    let mut rows: Vec<PlanRow> = p
        .known
        .iter()
        .map(|(key, (isa, timings))| PlanRow {
            key: key.clone(),
            chosen: Some(isa.name()),
            timings: timings.clone(),
        })
        .collect();
    for e in p.entries.values() {
        if e.chosen.is_none() {
            rows.push(PlanRow {
                key: e.key.clone(),
                chosen: None,
                timings: String::new(),
            });
        }
    }
    rows.sort_by(|a, b| a.key.cmp(&b.key));
    rows
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_drop_module_paths_and_keep_the_size_class() {
        struct Loop<T>(T);
        let id = Id::of::<Loop<Vec<f64>>>(65536);
        assert_eq!(id.size_class, 16);
        assert_eq!(Id::of::<u8>(65537).size_class, 17);
        assert_eq!(key_text(id), "Loop<Vec<f64>> n<=2^16");
    }

    #[test]
    fn a_cached_plan_that_did_not_measure_a_candidate_is_measured_again() {
        let timings = "avx2=0.5 baseline=1";
        assert!(measured_all(timings, &[Isa::Avx2, Isa::Baseline]));
        assert!(measured_all(timings, &[Isa::Baseline]));
        assert!(!measured_all(
            timings,
            &[Isa::Avx512, Isa::Avx2, Isa::Baseline]
        ));
        struct Cached;
        let id = Id::of::<Cached>(6);
        lock()
            .known
            .insert(key_text(id), (Isa::Avx2, timings.to_string()));
        let wider = [Isa::Avx512, Isa::Avx2, Isa::Baseline];
        assert!(matches!(next(id, &wider), Next::Measure(Isa::Avx512, _)));
        struct CachedToo;
        let id = Id::of::<CachedToo>(6);
        lock()
            .known
            .insert(key_text(id), (Isa::Avx2, timings.to_string()));
        assert!(matches!(
            next(id, &[Isa::Avx2, Isa::Baseline]),
            Next::Use(Isa::Avx2)
        ));
    }

    #[test]
    fn measuring_visits_every_copy_then_keeps_the_fastest() {
        struct Probe;
        let id = Id::of::<Probe>(6);
        let copies = [Isa::Avx2, Isa::Baseline];
        // avx2 takes 10 ns a step, the baseline 5: the baseline is chosen.
        for _ in 0..100 {
            match next(id, &copies) {
                Next::Use(isa) => {
                    assert_eq!(isa, Isa::Baseline);
                    assert_eq!(chosen(id), Some(Isa::Baseline));
                    return;
                }
                Next::Measure(isa, steps) => {
                    let per = if isa == Isa::Avx2 { 10.0 } else { 5.0 };
                    record(id, isa, &copies, per * steps as f64, steps);
                }
            }
        }
        panic!("no copy chosen after 100 pieces");
    }

    #[test]
    fn a_narrower_copy_must_be_faster_by_more_than_the_margin() {
        // the baseline 4% faster than AVX2: within the clock's noise, the wider copy is kept; 6%
        // faster: the baseline
        for (baseline_ns, expected) in [(9.6, Isa::Avx2), (9.4, Isa::Baseline)] {
            // (the planner is one per process and keys loops by type name: names of their own)
            struct WithinTheMargin;
            struct BeyondTheMargin;
            let id = if expected == Isa::Avx2 {
                Id::of::<WithinTheMargin>(6)
            } else {
                Id::of::<BeyondTheMargin>(6)
            };
            let copies = [Isa::Avx2, Isa::Baseline];
            let chosen = (0..100).find_map(|_| match next(id, &copies) {
                Next::Use(isa) => Some(isa),
                Next::Measure(isa, steps) => {
                    let per = if isa == Isa::Avx2 { 10.0 } else { baseline_ns };
                    record(id, isa, &copies, per * steps as f64, steps);
                    None
                }
            });
            assert_eq!(chosen, Some(expected), "baseline at {baseline_ns} ns");
        }
    }
}

//! Energies as per-coordinate quadratic forms plus U, and the streaming recorder that
//! tracks them at every step.
//!
//! Channels, in this order (paper §2.1 and (mod-energies)):
//! `total`, `oscillatory` (H_ω = Σ_{j≥1} I_j), `slow` (½|p₀|² + U), `modified_oscillatory`
//! (H*_ω = Σ_i ½(a_i p_i² + b_i q_i²)), then the per-block oscillatory energies I_1 … I_ℓ.

use crate::error::{CoreError, CoreResult};
use crate::stepper::Storage;

pub const TOTAL: usize = 0;
pub const OSCILLATORY: usize = 1;
pub const SLOW: usize = 2;
pub const MODIFIED: usize = 3;
/// Index of the first per-block channel (I_1).
pub const FIRST_BLOCK: usize = 4;

/// Weights of the energy quadratic forms.
#[derive(Debug, Clone)]
pub struct EnergyLayout {
    /// ω_i², the weight of ½q_i² in I_j.
    pub omega2: Vec<f64>,
    /// Weight of ½p_i² in the modified oscillatory energy (0 on slow coordinates).
    pub modified_p: Vec<f64>,
    /// Weight of ½q_i² in the modified oscillatory energy (0 on slow coordinates).
    pub modified_q: Vec<f64>,
    /// Block of coordinate i: 0 is slow, 1..=ℓ the oscillatory blocks.
    pub block: Vec<usize>,
    /// ℓ, the number of oscillatory blocks.
    pub n_blocks: usize,
}

impl EnergyLayout {
    pub fn dim(&self) -> usize {
        self.omega2.len()
    }

    pub fn n_channels(&self) -> usize {
        FIRST_BLOCK + self.n_blocks
    }

    pub fn validate(&self, n: usize) -> CoreResult<()> {
        for (name, len) in [
            ("omega2", self.omega2.len()),
            ("modified_p", self.modified_p.len()),
            ("modified_q", self.modified_q.len()),
            ("block", self.block.len()),
        ] {
            if len != n {
                return Err(CoreError::invalid(
                    "energy layout",
                    format!("`{name}` has {len} entries for {n} coordinates"),
                ));
            }
        }
        if let Some(i) = self.block.iter().position(|&b| b > self.n_blocks) {
            return Err(CoreError::invalid(
                "energy layout",
                format!(
                    "coordinate {i} is in block {} but there are {} blocks",
                    self.block[i], self.n_blocks
                ),
            ));
        }
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        if !(finite(&self.omega2) && finite(&self.modified_p) && finite(&self.modified_q)) {
            return Err(CoreError::invalid(
                "energy layout",
                "weights must be finite",
            ));
        }
        Ok(())
    }

    /// 1.0 on the slow coordinates (block 0) and 0.0 elsewhere when `slow`, the reverse otherwise:
    /// the masks that let the energy sums run without branches.
    pub fn mask(&self, slow: bool) -> Vec<f64> {
        self.block
            .iter()
            .map(|&b| if (b == 0) == slow { 1.0 } else { 0.0 })
            .collect()
    }

    /// True when the modified oscillatory energy is the plain one (σ ≡ 1, ω̃ = ω),
    /// so the kernel can copy it instead of summing it again.
    pub fn modified_is_plain(&self) -> bool {
        (0..self.dim()).all(|i| {
            let slow = self.block[i] == 0;
            let (a, b) = (self.modified_p[i], self.modified_q[i]);
            if slow {
                a == 0.0 && b == 0.0
            } else {
                a == 1.0 && b == self.omega2[i]
            }
        })
    }

    /// All channels at one state, straightforwardly (the streaming recorder computes the same
    /// sums branch-free; this is the plain version for checks).
    pub fn evaluate(&self, q: &[f64], p: &[f64], u: f64) -> Vec<f64> {
        let mut blocks = vec![0.0; self.n_blocks + 1];
        let mut out = vec![0.0; self.n_channels()];
        let mut modified = 0.0;
        for i in 0..q.len() {
            let (qi, pi) = (q[i], p[i]);
            blocks[self.block[i]] += 0.5 * (pi * pi + self.omega2[i] * (qi * qi));
            modified += 0.5 * (self.modified_p[i] * (pi * pi) + self.modified_q[i] * (qi * qi));
        }
        let oscillatory: f64 = blocks[1..].iter().sum();
        out[TOTAL] = oscillatory + (blocks[0] + u);
        out[OSCILLATORY] = oscillatory;
        out[SLOW] = blocks[0] + u;
        out[MODIFIED] = modified;
        out[FIRST_BLOCK..].copy_from_slice(&blocks[1..]);
        out
    }
}

/// Whether every entry is finite: an OR over the exponent bits, which vectorizes (a floating-point
/// sum would be a sequential chain of additions).
#[inline(always)]
pub fn all_finite(x: &[f64]) -> bool {
    const EXPONENT: u64 = 0x7ff0_0000_0000_0000;
    let mut bad = 0u64;
    for &v in x {
        bad |= u64::from(v.to_bits() & EXPONENT == EXPONENT);
    }
    bad == 0
}

/// Saved states: step indices, then row-major q, p and energy rows.
#[derive(Debug, Clone, Default)]
pub struct Samples {
    pub steps: Vec<u64>,
    pub q: Vec<f64>,
    pub p: Vec<f64>,
    pub energies: Vec<f64>,
}

/// The energy weights in the kernel's storage, with 0/1 masks for the slow and fast
/// coordinates so that the sums need no branches.
struct Weights<S> {
    omega2: S,
    fast: S,
    slow: S,
    modified_p: S,
    modified_q: S,
}

/// Streams the energies at every step: max |E(t_n) − E(0)| per channel, and the samples
/// at steps 0, s, 2s, … and the last step. Memory is O(samples), never O(steps).
pub struct Recorder<'a, S> {
    layout: &'a EnergyLayout,
    w: Weights<S>,
    plain_modified: bool,
    /// ℓ > 1: the per-block channels need their own sums (for ℓ = 1, I_1 = H_ω).
    several_blocks: bool,
    /// Track the energies at every step; otherwise only at samples (and check finiteness).
    track: bool,
    save_every: u64,
    last_step: u64,
    until_sample: u64,
    /// The four main channels at the current step, and their running extremes.
    main: [f64; FIRST_BLOCK],
    main_high: [f64; FIRST_BLOCK],
    main_low: [f64; FIRST_BLOCK],
    blocks: Vec<f64>,
    blocks_high: Vec<f64>,
    blocks_low: Vec<f64>,
    initial: Vec<f64>,
    row: Vec<f64>,
    pub samples: Samples,
}

impl<'a, S: Storage> Recorder<'a, S> {
    pub fn new(layout: &'a EnergyLayout, track: bool, save_every: u64, last_step: u64) -> Self {
        let n = layout.dim();
        let c = layout.n_channels();
        let l = layout.n_blocks;
        let n_samples = (last_step / save_every.max(1) + 2).min(1 << 20) as usize;
        Recorder {
            layout,
            w: Weights {
                omega2: S::from_slice(&layout.omega2),
                fast: S::from_slice(&layout.mask(false)),
                slow: S::from_slice(&layout.mask(true)),
                modified_p: S::from_slice(&layout.modified_p),
                modified_q: S::from_slice(&layout.modified_q),
            },
            plain_modified: layout.modified_is_plain(),
            several_blocks: l > 1,
            track,
            save_every: save_every.max(1),
            last_step,
            until_sample: 0,
            main: [0.0; FIRST_BLOCK],
            main_high: [f64::NEG_INFINITY; FIRST_BLOCK],
            main_low: [f64::INFINITY; FIRST_BLOCK],
            blocks: vec![0.0; l + 1],
            blocks_high: vec![f64::NEG_INFINITY; l],
            blocks_low: vec![f64::INFINITY; l],
            initial: vec![f64::NAN; c],
            row: vec![0.0; c],
            samples: Samples {
                steps: Vec::with_capacity(n_samples),
                q: Vec::with_capacity(n_samples * n),
                p: Vec::with_capacity(n_samples * n),
                energies: Vec::with_capacity(n_samples * c),
            },
        }
    }

    /// Whether U(q_n) is needed when step `n` is observed.
    #[inline(always)]
    pub fn needs_potential_at(&self, n: u64) -> bool {
        self.track || self.is_sample(n)
    }

    #[inline(always)]
    fn is_sample(&self, n: u64) -> bool {
        // `until_sample` counts down from save_every after each sample.
        self.until_sample == 0 || n == self.last_step
    }

    /// The four main channels (and the per-block sums when ℓ > 1) at one state, returned by
    /// value: they stay in registers for the max/min updates (storing them and loading them
    /// back in another width stalls store forwarding).
    #[inline(always)]
    fn evaluate(&mut self, q: &[f64], p: &[f64], u: f64) -> [f64; FIRST_BLOCK] {
        let w = &mut self.w;
        let n = q.len();
        let (p, omega2, fast, slow) = (
            &p[..n],
            &w.omega2.get()[..n],
            &w.fast.get()[..n],
            &w.slow.get()[..n],
        );
        let (mp, mq) = (&w.modified_p.get()[..n], &w.modified_q.get()[..n]);
        let (mut oscillatory, mut kinetic_slow, mut modified) = (0.0, 0.0, 0.0);
        for i in 0..n {
            let (pp, qq) = (p[i] * p[i], q[i] * q[i]);
            let e = 0.5 * (pp + omega2[i] * qq);
            oscillatory += fast[i] * e;
            kinetic_slow += slow[i] * e;
            if !self.plain_modified {
                modified += 0.5 * (mp[i] * pp + mq[i] * qq);
            }
        }
        if self.several_blocks {
            self.block_sums(q, p);
        }
        let slow_energy = kinetic_slow + u;
        [
            oscillatory + slow_energy,
            oscillatory,
            slow_energy,
            if self.plain_modified {
                oscillatory
            } else {
                modified
            },
        ]
    }

    /// I_1 … I_ℓ into `blocks[1..]`, for ℓ > 1.
    #[inline(never)]
    fn block_sums(&mut self, q: &[f64], p: &[f64]) {
        self.blocks.fill(0.0);
        let omega2 = self.w.omega2.get();
        for (i, &b) in self.layout.block.iter().enumerate() {
            self.blocks[b] += 0.5 * (p[i] * p[i] + omega2[i] * (q[i] * q[i]));
        }
    }

    /// All channels of the current step in output order.
    fn current_row(&mut self) {
        self.row[..FIRST_BLOCK].copy_from_slice(&self.main);
        if self.several_blocks {
            self.row[FIRST_BLOCK..].copy_from_slice(&self.blocks[1..]);
        } else if self.layout.n_blocks == 1 {
            self.row[FIRST_BLOCK] = self.main[OSCILLATORY];
        }
    }

    /// Observes the state at step n; returns false if it is not finite (a blow-up).
    #[inline(always)]
    pub fn observe(&mut self, n: u64, q: &[f64], p: &[f64], u: f64) -> bool {
        let sample = self.is_sample(n);
        if self.track || sample {
            let main = self.evaluate(q, p, u);
            // Any non-finite coordinate, momentum or U makes the total non-finite.
            if !main[TOTAL].is_finite() {
                return false;
            }
            self.main = main;
            if self.track {
                // Whole-array loads and stores, so that every access has the same width.
                let (mut high, mut low) = (self.main_high, self.main_low);
                for c in 0..FIRST_BLOCK {
                    high[c] = if main[c] > high[c] { main[c] } else { high[c] };
                    low[c] = if main[c] < low[c] { main[c] } else { low[c] };
                }
                self.main_high = high;
                self.main_low = low;
                if self.several_blocks {
                    for j in 0..self.blocks_high.len() {
                        let e = self.blocks[j + 1];
                        self.blocks_high[j] = self.blocks_high[j].max(e);
                        self.blocks_low[j] = self.blocks_low[j].min(e);
                    }
                }
            }
        } else if !all_finite(q) {
            return false;
        }
        if sample {
            self.record_sample(n, q, p);
        }
        self.until_sample -= 1;
        true
    }

    #[cold]
    fn record_sample(&mut self, n: u64, q: &[f64], p: &[f64]) {
        self.current_row();
        if n == 0 {
            self.initial.copy_from_slice(&self.row);
        }
        self.samples.steps.push(n);
        self.samples.q.extend_from_slice(q);
        self.samples.p.extend_from_slice(p);
        self.samples.energies.extend_from_slice(&self.row);
        self.until_sample = self.save_every;
    }

    /// The energies at step 0.
    pub fn initial(&self) -> &[f64] {
        &self.initial
    }

    /// max_n |E(t_n) − E(0)| per channel over every observed step; NaN if not tracked.
    ///
    /// Rounding is monotone, so max(E_n) − E_0 equals max(E_n − E_0) bit for bit.
    pub fn max_deviation(&self) -> Vec<f64> {
        if !self.track {
            return vec![f64::NAN; self.initial.len()];
        }
        let mut high = self.main_high.to_vec();
        let mut low = self.main_low.to_vec();
        if self.several_blocks {
            high.extend_from_slice(&self.blocks_high);
            low.extend_from_slice(&self.blocks_low);
        } else if self.layout.n_blocks == 1 {
            high.push(self.main_high[OSCILLATORY]);
            low.push(self.main_low[OSCILLATORY]);
        }
        self.initial
            .iter()
            .zip(high.iter().zip(&low))
            .map(|(&e0, (&hi, &lo))| (hi - e0).max(e0 - lo))
            .collect()
    }
}

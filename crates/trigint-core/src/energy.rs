//! Energies as per-coordinate quadratic forms plus U, and the streaming recorder that
//! tracks them at every step.
//!
//! Channels, in this order (paper §2.1 and (mod-energies)):
//! `total`, `oscillatory` (H_ω = Σ_{j≥1} I_j), `slow` (½|p₀|² + U), `modified_oscillatory`
//! (H*_ω = Σ_i ½(a_i p_i² + b_i q_i²)), then the per-block oscillatory energies I_1 … I_ℓ.

use crate::error::{CoreError, CoreResult};

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
                format!("coordinate {i} is in block {} but there are {} blocks", self.block[i], self.n_blocks),
            ));
        }
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        if !(finite(&self.omega2) && finite(&self.modified_p) && finite(&self.modified_q)) {
            return Err(CoreError::invalid("energy layout", "weights must be finite"));
        }
        Ok(())
    }

    /// True when the modified oscillatory energy is the plain one (σ ≡ 1, ω̃ = ω),
    /// so the kernel can copy it instead of summing it again.
    pub fn modified_is_plain(&self) -> bool {
        (0..self.dim()).all(|i| {
            let slow = self.block[i] == 0;
            let (a, b) = (self.modified_p[i], self.modified_q[i]);
            if slow { a == 0.0 && b == 0.0 } else { a == 1.0 && b == self.omega2[i] }
        })
    }

    /// All channels at one state. `blocks` is scratch of length ℓ + 1.
    #[inline(always)]
    pub fn evaluate(&self, plain_modified: bool, q: &[f64], p: &[f64], u: f64, blocks: &mut [f64], out: &mut [f64]) {
        blocks.fill(0.0);
        let mut modified = 0.0;
        for i in 0..q.len() {
            let (qi, pi) = (q[i], p[i]);
            blocks[self.block[i]] += 0.5 * (pi * pi + self.omega2[i] * (qi * qi));
            if !plain_modified {
                modified += 0.5 * (self.modified_p[i] * (pi * pi) + self.modified_q[i] * (qi * qi));
            }
        }
        let mut oscillatory = 0.0;
        for (j, &e) in blocks.iter().enumerate().skip(1) {
            oscillatory += e;
            out[FIRST_BLOCK + j - 1] = e;
        }
        let slow = blocks[0] + u;
        out[TOTAL] = oscillatory + slow;
        out[OSCILLATORY] = oscillatory;
        out[SLOW] = slow;
        out[MODIFIED] = if plain_modified { oscillatory } else { modified };
    }
}

/// Saved states: step indices, then row-major q, p and energy rows.
#[derive(Debug, Clone, Default)]
pub struct Samples {
    pub steps: Vec<u64>,
    pub q: Vec<f64>,
    pub p: Vec<f64>,
    pub energies: Vec<f64>,
}

/// Streams the energies at every step: max |E(t_n) − E(0)| per channel, and the samples
/// at steps 0, s, 2s, … and the last step. Memory is O(samples), never O(steps).
pub struct Recorder<'a> {
    layout: &'a EnergyLayout,
    plain_modified: bool,
    /// Track the energies at every step; otherwise only at samples (and check finiteness).
    track: bool,
    save_every: u64,
    last_step: u64,
    until_sample: u64,
    blocks: Vec<f64>,
    current: Vec<f64>,
    initial: Vec<f64>,
    highest: Vec<f64>,
    lowest: Vec<f64>,
    pub samples: Samples,
}

impl<'a> Recorder<'a> {
    pub fn new(layout: &'a EnergyLayout, track: bool, save_every: u64, last_step: u64) -> Self {
        let c = layout.n_channels();
        let n_samples = (last_step / save_every.max(1) + 2).min(1 << 20) as usize;
        let n = layout.dim();
        Recorder {
            layout,
            plain_modified: layout.modified_is_plain(),
            track,
            save_every: save_every.max(1),
            last_step,
            until_sample: 0,
            blocks: vec![0.0; layout.n_blocks + 1],
            current: vec![0.0; c],
            initial: vec![f64::NAN; c],
            highest: vec![f64::NEG_INFINITY; c],
            lowest: vec![f64::INFINITY; c],
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

    /// Observes the state at step n; returns false if it is not finite (a blow-up).
    #[inline(always)]
    pub fn observe(&mut self, n: u64, q: &[f64], p: &[f64], u: f64) -> bool {
        let sample = self.is_sample(n);
        if self.track || sample {
            self.layout.evaluate(self.plain_modified, q, p, u, &mut self.blocks, &mut self.current);
            // A non-finite state makes the total energy non-finite (or U did overflow).
            if !self.current.iter().all(|e| e.is_finite()) {
                return false;
            }
            if n == 0 {
                self.initial.copy_from_slice(&self.current);
            }
            if self.track {
                for ((hi, lo), &e) in self.highest.iter_mut().zip(self.lowest.iter_mut()).zip(&self.current) {
                    *hi = hi.max(e);
                    *lo = lo.min(e);
                }
            }
        } else if !(q.iter().chain(p).all(|x| x.is_finite())) {
            return false;
        }
        if sample {
            self.samples.steps.push(n);
            self.samples.q.extend_from_slice(q);
            self.samples.p.extend_from_slice(p);
            self.samples.energies.extend_from_slice(&self.current);
            self.until_sample = self.save_every;
        }
        self.until_sample -= 1;
        true
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
        self.initial
            .iter()
            .zip(self.highest.iter().zip(&self.lowest))
            .map(|(&e0, (&hi, &lo))| (hi - e0).max(e0 - lo))
            .collect()
    }
}

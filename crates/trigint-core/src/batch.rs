//! The batched kernel: many trajectories of one problem, each with its own initial values and
//! step size (hence its own coefficients and step count).
//!
//! Trajectories are sorted by step count and cut into blocks of a few hundred; a block is
//! stepped in structure-of-arrays layout (coordinate-major, x[i * lanes + b]) so that every
//! loop runs across lanes and vectorizes. Each lane performs exactly the operations of the
//! single-trajectory two-step kernel ([`crate::stepper::TwoStep`]) in the same order, so its
//! numbers are bit for bit those of [`crate::integrate`] on that trajectory alone, whatever
//! the block size, the thread count or the other trajectories in the batch. Blocks run in
//! parallel with rayon.

use std::sync::atomic::{AtomicBool, Ordering};

use rayon::prelude::*;

use crate::coefficients::{KernelCoefficients, MethodCoefficients};
use crate::driver::Status;
use crate::energy::{EnergyLayout, Samples, FIRST_BLOCK, OSCILLATORY};
use crate::error::{CoreError, CoreResult};
use crate::potential::Potential;

/// What a batch run is asked to do.
#[derive(Debug, Clone)]
pub struct BatchSpec {
    /// Keep samples every this many steps (and at each trajectory's last step); None: none.
    pub save_every: Option<u64>,
    /// Track the maximum deviation of every energy at every step.
    pub track_energies: bool,
    /// Trajectories per block; 0 picks a cache-sized block for the dimension.
    pub block: usize,
}

/// The result for one trajectory of a batch.
#[derive(Debug, Clone)]
pub struct TrajectoryOutput {
    pub status: Status,
    pub steps_done: u64,
    pub initial_energies: Vec<f64>,
    pub max_deviation: Vec<f64>,
    pub samples: Samples,
}

/// Untracked steps check that the state is finite every this many steps (and at samples).
const FINITE_CHECK_EVERY: u64 = 64;

/// Lanes per block: about 256 KiB of state and coefficients, at most 256 lanes.
pub fn default_block(n: usize) -> usize {
    let bytes_per_lane = 8 * n * 16;
    (256 * 1024 / bytes_per_lane.max(1)).clamp(1, 256)
}

/// One trajectory of a batch: its method coefficients (they carry its step size) and the
/// weights of its modified oscillatory energy, which depend on the step size too.
#[derive(Debug, Clone)]
pub struct TrajectoryMethod {
    pub coefficients: MethodCoefficients,
    pub modified_p: Vec<f64>,
    pub modified_q: Vec<f64>,
}

/// Integrates every trajectory; `q0`, `p0` are row-major (B × n); `layout` gives the
/// frequencies and blocks (its modified weights are replaced by each trajectory's). `stop` is
/// polled every few thousand steps: once set, unfinished trajectories end Interrupted.
#[allow(clippy::too_many_arguments)]
pub fn integrate_batch<P: Potential>(
    pot: &P,
    methods: &[TrajectoryMethod],
    layout: &EnergyLayout,
    q0: &[f64],
    p0: &[f64],
    n_steps: &[u64],
    spec: &BatchSpec,
    stop: &AtomicBool,
) -> CoreResult<Vec<TrajectoryOutput>> {
    let coefficients: Vec<&MethodCoefficients> = methods.iter().map(|m| &m.coefficients).collect();
    let count = coefficients.len();
    if count == 0 {
        return Err(CoreError::invalid("q0", "the batch is empty"));
    }
    let n = coefficients[0].dim();
    for (t, c) in coefficients.iter().enumerate() {
        c.validate()
            .map_err(|e| CoreError::invalid("coefficients", format!("trajectory {t}: {e}")))?;
        let m = &methods[t];
        if c.dim() != n || m.modified_p.len() != n || m.modified_q.len() != n {
            return Err(CoreError::invalid(
                "coefficients",
                format!("trajectory {t} does not have {n} coordinates"),
            ));
        }
        if !m
            .modified_p
            .iter()
            .chain(&m.modified_q)
            .all(|x| x.is_finite())
        {
            return Err(CoreError::invalid(
                "coefficients",
                format!("trajectory {t}: energy weights must be finite"),
            ));
        }
    }
    for (name, v) in [("q0", q0), ("p0", p0)] {
        if v.len() != count * n {
            return Err(CoreError::invalid(
                name,
                format!("expected {count} x {n} values, got {}", v.len()),
            ));
        }
        if let Some(i) = v.iter().position(|x| !x.is_finite()) {
            return Err(CoreError::invalid(
                name,
                format!("trajectory {}: entry {} is not finite", i / n, i % n),
            ));
        }
    }
    if n_steps.len() != count {
        return Err(CoreError::invalid(
            "n_steps",
            format!("expected {count} step counts, got {}", n_steps.len()),
        ));
    }
    if spec.save_every == Some(0) {
        return Err(CoreError::invalid("save_every", "must be >= 1"));
    }
    pot.check_dim(n)?;
    layout.validate(n)?;
    let block = if spec.block == 0 {
        default_block(n)
    } else {
        spec.block
    };
    // Sorted by step count, a block's active lanes are always a suffix of it.
    let mut order: Vec<usize> = (0..count).collect();
    order.sort_by_key(|&t| n_steps[t]);
    let blocks: Vec<&[usize]> = order.chunks(block).collect();
    let results: Vec<CoreResult<Vec<TrajectoryOutput>>> = blocks
        .par_iter()
        .map(|ids| {
            run_block(
                Block::new(pot, methods, layout, q0, p0, n_steps, ids, spec),
                stop,
            )
        })
        .collect();
    let mut out: Vec<Option<TrajectoryOutput>> = vec![None; count];
    for (ids, result) in blocks.iter().zip(results) {
        for (&t, r) in ids.iter().zip(result?) {
            out[t] = Some(r);
        }
    }
    Ok(out
        .into_iter()
        .map(|r| r.expect("every trajectory belongs to one block"))
        .collect())
}

/// Runs a block with the widest vectors this CPU has. The three copies of the kernel differ only
/// in instruction encoding: no fused multiply-add is ever formed (Rust does not contract a·b + c),
/// so every copy produces the same bits.
fn run_block<P: Potential>(
    block: Block<P>,
    stop: &AtomicBool,
) -> CoreResult<Vec<TrajectoryOutput>> {
    #[cfg(target_arch = "x86_64")]
    {
        if std::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU supports AVX-512F, checked just above.
            return unsafe { run_block_avx512(block, stop) };
        }
        if std::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            return unsafe { run_block_avx2(block, stop) };
        }
    }
    block.run(stop)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn run_block_avx512<P: Potential>(
    block: Block<P>,
    stop: &AtomicBool,
) -> CoreResult<Vec<TrajectoryOutput>> {
    block.run(stop)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn run_block_avx2<P: Potential>(
    block: Block<P>,
    stop: &AtomicBool,
) -> CoreResult<Vec<TrajectoryOutput>> {
    block.run(stop)
}

/// A zeroed buffer whose first element starts a cache line (64 bytes): with a multiple of 8
/// lanes every row of a block starts one too, and wide vector loads never straddle two lines.
#[derive(Default)]
struct Aligned {
    buf: Vec<f64>,
    start: usize,
    len: usize,
}

impl Aligned {
    fn zeros(len: usize) -> Self {
        let buf = vec![0.0; len + 8];
        let start = buf.as_ptr().align_offset(64).min(8);
        Aligned { buf, start, len }
    }
}

impl std::ops::Deref for Aligned {
    type Target = [f64];
    fn deref(&self) -> &[f64] {
        &self.buf[self.start..self.start + self.len]
    }
}

impl std::ops::DerefMut for Aligned {
    fn deref_mut(&mut self) -> &mut [f64] {
        &mut self.buf[self.start..self.start + self.len]
    }
}

/// Per-lane numbers in coordinate-major order.
fn transpose(rows: &[&[f64]], n: usize) -> Aligned {
    let lanes = rows.len();
    let mut out = Aligned::zeros(n * lanes);
    for (b, r) in rows.iter().enumerate() {
        for i in 0..n {
            out[i * lanes + b] = r[i];
        }
    }
    out
}

struct Block<'a, P> {
    pot: &'a P,
    layout: &'a EnergyLayout,
    n: usize,
    lanes: usize,
    n_steps: Vec<u64>,
    spec: &'a BatchSpec,
    phi_is_identity: bool,
    /// H* is H_ω for every lane (σ ≡ 1, ω̃ = ω): its sums are skipped and copied.
    plain_modified: bool,
    // coefficients, coordinate-major
    omc: Aligned,
    two_omc: Aligned,
    h2_psi: Aligned,
    half_h2_psi: Aligned,
    phi: Aligned,
    inv_2h_chi: Aligned,
    h_chi: Aligned,
    modified_p: Aligned,
    modified_q: Aligned,
    fast: Vec<f64>,
    slow: Vec<f64>,
    /// Every lane has the same coefficients (one step size): rows are broadcast numbers.
    uniform: bool,
    // state
    q: Aligned,
    p0: Aligned,
}

impl<'a, P: Potential> Block<'a, P> {
    #[allow(clippy::too_many_arguments)]
    fn new(
        pot: &'a P,
        methods: &[TrajectoryMethod],
        layout: &'a EnergyLayout,
        q0: &[f64],
        p0: &[f64],
        n_steps: &[u64],
        ids: &[usize],
        spec: &'a BatchSpec,
    ) -> Self {
        let n = layout.dim();
        let kernels: Vec<KernelCoefficients> = ids
            .iter()
            .map(|&t| methods[t].coefficients.kernel())
            .collect();
        let pick = |f: fn(&KernelCoefficients) -> &Vec<f64>| -> Aligned {
            transpose(
                &kernels.iter().map(|k| f(k).as_slice()).collect::<Vec<_>>(),
                n,
            )
        };
        let rows = |v: &[f64]| -> Aligned {
            transpose(
                &ids.iter()
                    .map(|&t| &v[t * n..(t + 1) * n])
                    .collect::<Vec<_>>(),
                n,
            )
        };
        let lanes = ids.len();
        let plain_modified = ids.iter().all(|&t| {
            let m = &methods[t];
            (0..n).all(|i| {
                let fast = layout.block[i] != 0;
                let (a, b) = (m.modified_p[i], m.modified_q[i]);
                if fast {
                    a == 1.0 && b == layout.omega2[i]
                } else {
                    a == 0.0 && b == 0.0
                }
            })
        });
        let first = &methods[ids[0]];
        let uniform = ids.iter().all(|&t| {
            let (m, c) = (&methods[t], &methods[t].coefficients);
            let f = &first.coefficients;
            c.h == f.h
                && c.one_minus_cos == f.one_minus_cos
                && c.sin == f.sin
                && c.chi == f.chi
                && c.psi == f.psi
                && c.phi == f.phi
                && m.modified_p == first.modified_p
                && m.modified_q == first.modified_q
        });
        Block {
            uniform,
            plain_modified,
            pot,
            layout,
            n,
            lanes,
            n_steps: ids.iter().map(|&t| n_steps[t]).collect(),
            spec,
            phi_is_identity: kernels.iter().all(|k| k.phi_is_identity),
            omc: pick(|k| &k.one_minus_cos),
            two_omc: pick(|k| &k.two_one_minus_cos),
            h2_psi: pick(|k| &k.h2_psi),
            half_h2_psi: pick(|k| &k.half_h2_psi),
            phi: pick(|k| &k.phi),
            inv_2h_chi: pick(|k| &k.inv_2h_chi),
            h_chi: pick(|k| &k.h_chi),
            modified_p: transpose(
                &ids.iter()
                    .map(|&t| methods[t].modified_p.as_slice())
                    .collect::<Vec<_>>(),
                n,
            ),
            modified_q: transpose(
                &ids.iter()
                    .map(|&t| methods[t].modified_q.as_slice())
                    .collect::<Vec<_>>(),
                n,
            ),
            fast: layout.mask(false),
            slow: layout.mask(true),
            q: rows(q0),
            p0: rows(p0),
        }
    }

    /// g(φq) into `f` and, when `with_value`, U(q) into `u` (as the scalar `evaluate`).
    #[inline(always)]
    fn evaluate(
        &self,
        q: &[f64],
        x: &mut [f64],
        f: &mut [f64],
        u: &mut [f64],
        with_value: bool,
    ) -> CoreResult<()> {
        if self.phi_is_identity {
            self.pot.force_lanes(q, f, u, with_value, self.lanes)
        } else {
            let len = q.len();
            let (x, phi) = (&mut x[..len], &self.phi[..len]);
            for j in 0..len {
                x[j] = phi[j] * q[j];
            }
            self.pot.force_lanes(x, f, u, false, self.lanes)?;
            if with_value {
                self.pot.value_lanes(q, u, self.lanes)?;
            }
            Ok(())
        }
    }

    #[inline(always)]
    fn run(mut self, stop: &AtomicBool) -> CoreResult<Vec<TrajectoryOutput>> {
        let (n, lanes) = (self.n, self.lanes);
        let len = n * lanes;
        let mut rec = LaneRecorder::new(
            self.layout,
            lanes,
            self.spec,
            &self.n_steps,
            self.plain_modified,
        );
        let mut q = std::mem::take(&mut self.q);
        let p0 = std::mem::take(&mut self.p0);
        let (mut d, mut p, mut f, mut x) = (
            Aligned::zeros(len),
            Aligned::zeros(len),
            Aligned::zeros(len),
            Aligned::zeros(len),
        );
        let mut u = vec![f64::NAN; lanes];
        self.evaluate(&q, &mut x, &mut f, &mut u, true)?;
        rec.energies(&self, &q, &p0);
        rec.observe(&self, 0, &q, &p0, &u, 0);
        // (trigo-q1) in summed form: d_1 = −(1 − c) q_0 + hχ p_0 + ½h²ψ g_0; q_1 = q_0 + d_1.
        {
            let (omc, h_chi, half) = (
                &self.omc[..len],
                &self.h_chi[..len],
                &self.half_h2_psi[..len],
            );
            let (q, d, f, p0) = (&mut q[..len], &mut d[..len], &f[..len], &p0[..len]);
            for j in 0..len {
                d[j] = -(omc[j] * q[j]) + h_chi[j] * p0[j] + half[j] * f[j];
                q[j] += d[j];
            }
        }
        let last = *self.n_steps.iter().max().unwrap_or(&0);
        let mut first_active = 0; // lanes before it have taken all their steps
        self.evaluate(&q, &mut x, &mut f, &mut u, rec.needs_potential_at(1))?;
        for step in 1..=last {
            while first_active < lanes && self.n_steps[first_active] < step {
                first_active += 1;
            }
            let energies = rec.needs_potential_at(step);
            // Samples (and per-block sums) need p_n and q_n after the sweep; other steps fold
            // q_{n+1} = q_n + d_{n+1} into it.
            let full = rec.needs_state(step, first_active);
            let check = energies || step % FINITE_CHECK_EVERY == 0;
            let mode = match (energies, full, check) {
                (false, _, false) => sweep::Mode::Advance,
                (false, _, true) => sweep::Mode::AdvanceAndSum,
                (true, false, _) => sweep::Mode::Track,
                (true, true, _) => sweep::Mode::Sample,
            };
            rec.start_step(energies, check);
            for i in 0..n {
                let row = i * lanes..(i + 1) * lanes;
                let (q, d, f, p) = (
                    &mut q[row.clone()],
                    &mut d[row.clone()],
                    &f[row.clone()],
                    &mut p[row.clone()],
                );
                let (mp, mq) = (&self.modified_p[row.clone()], &self.modified_q[row.clone()]);
                let fast_row = self.fast[i] == 1.0;
                let w2 = self.layout.omega2[i];
                let (osc, kin, modi, sums) = rec.accumulators();
                let sums = if !energies {
                    sums
                } else if fast_row {
                    osc
                } else {
                    kin
                };
                let modified = if self.plain_modified || !energies {
                    None
                } else {
                    Some((mp, mq, modi))
                };
                if self.uniform {
                    let k = i * lanes;
                    let coef = (
                        sweep::Same(self.two_omc[k]),
                        sweep::Same(self.h2_psi[k]),
                        sweep::Same(self.inv_2h_chi[k]),
                    );
                    sweep::row(mode, q, d, f, p, coef, w2, sums, modified);
                } else {
                    let coef = (
                        &self.two_omc[row.clone()],
                        &self.h2_psi[row.clone()],
                        &self.inv_2h_chi[row],
                    );
                    sweep::row(mode, q, d, f, p, coef, w2, sums, modified);
                }
            }
            if full {
                rec.observe(&self, step, &q, &p, &u, first_active);
                let (q, d) = (&mut q[..len], &d[..len]);
                for j in 0..len {
                    q[j] += d[j];
                }
            } else if check {
                rec.observe_lanes(step, &u, first_active);
            }
            for &b in &rec.newly_dead {
                // Park blown-up lanes at rest, so their NaNs stop reaching the checks.
                for i in 0..n {
                    q[i * lanes + b] = 0.0;
                    d[i * lanes + b] = 0.0;
                }
            }
            if step % 4096 == 0 && stop.load(Ordering::Relaxed) {
                rec.interrupt(step);
                break;
            }
            if step < last {
                self.evaluate(&q, &mut x, &mut f, &mut u, rec.needs_potential_at(step + 1))?;
            }
        }
        Ok(rec.finish())
    }
}

/// The sweeps over one coordinate row of a block: every row is its own slice argument, so the
/// slices are known not to overlap (noalias) and the loops vectorize across lanes. Per lane
/// they do the single-trajectory kernel's arithmetic: d_{n+1} = d_n − 2(1 − c) q_n + h²ψ g_n,
/// p_n = (d_{n+1} + d_n)/(2hχ), e = ½(p_n² + ω² q_n²) added to H_ω on a fast row or to the
/// slow kinetic energy on a slow row (the scalar recorder adds 1·e and 0·e: the same sums), and
/// ½(a p² + b q²) added to H* unless H* is H_ω.
mod sweep {
    /// A coefficient row: one number per lane, or one number for every lane of a block whose
    /// trajectories share their step size (then it stays in a register).
    pub trait Row: Copy {
        fn fit(self, len: usize) -> Self;
        fn at(self, b: usize) -> f64;
    }

    impl Row for &[f64] {
        #[inline(always)]
        fn fit(self, len: usize) -> Self {
            &self[..len]
        }
        #[inline(always)]
        fn at(self, b: usize) -> f64 {
            self[b]
        }
    }

    /// The same number for every lane.
    #[derive(Clone, Copy)]
    pub struct Same(pub f64);

    impl Row for Same {
        #[inline(always)]
        fn fit(self, _: usize) -> Self {
            self
        }
        #[inline(always)]
        fn at(self, _: usize) -> f64 {
            self.0
        }
    }

    /// Untracked steps: advance only.
    #[inline(always)]
    pub fn advance<R: Row>(q: &mut [f64], d: &mut [f64], f: &[f64], a: R, hp: R) {
        let l = q.len();
        let (d, f, a, hp) = (&mut d[..l], &f[..l], a.fit(l), hp.fit(l));
        for b in 0..l {
            let next = d[b] - a.at(b) * q[b] + hp.at(b) * f[b];
            d[b] = next;
            q[b] += next;
        }
    }

    /// Untracked steps that check finiteness: advance, with Σ q_n per lane.
    #[inline(always)]
    pub fn advance_and_sum<R: Row>(
        q: &mut [f64],
        d: &mut [f64],
        f: &[f64],
        a: R,
        hp: R,
        sum: &mut [f64],
    ) {
        let l = q.len();
        let (d, f, a, hp, sum) = (&mut d[..l], &f[..l], a.fit(l), hp.fit(l), &mut sum[..l]);
        for b in 0..l {
            let next = d[b] - a.at(b) * q[b] + hp.at(b) * f[b];
            sum[b] += q[b];
            d[b] = next;
            q[b] += next;
        }
    }

    /// Tracked steps without a sample: energies at (q_n, p_n), then advance.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub fn observe_and_advance<R: Row>(
        q: &mut [f64],
        d: &mut [f64],
        f: &[f64],
        a: R,
        hp: R,
        inv: R,
        w2: f64,
        sums: &mut [f64],
        modified: Option<(&[f64], &[f64], &mut [f64])>,
    ) {
        let l = q.len();
        let (d, f, a, hp, inv, sums) = (
            &mut d[..l],
            &f[..l],
            a.fit(l),
            hp.fit(l),
            inv.fit(l),
            &mut sums[..l],
        );
        match modified {
            None => {
                for b in 0..l {
                    let next = d[b] - a.at(b) * q[b] + hp.at(b) * f[b];
                    let p = (next + d[b]) * inv.at(b);
                    sums[b] += 0.5 * (p * p + w2 * (q[b] * q[b]));
                    d[b] = next;
                    q[b] += next;
                }
            }
            Some((mp, mq, modi)) => {
                let (mp, mq, modi) = (&mp[..l], &mq[..l], &mut modi[..l]);
                for b in 0..l {
                    let next = d[b] - a.at(b) * q[b] + hp.at(b) * f[b];
                    let p = (next + d[b]) * inv.at(b);
                    let (pp, qq) = (p * p, q[b] * q[b]);
                    sums[b] += 0.5 * (pp + w2 * qq);
                    modi[b] += 0.5 * (mp[b] * pp + mq[b] * qq);
                    d[b] = next;
                    q[b] += next;
                }
            }
        }
    }

    /// Sample steps: p_n stored and energies at (q_n, p_n); q is advanced afterwards.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub fn observe<R: Row>(
        q: &[f64],
        d: &mut [f64],
        f: &[f64],
        p: &mut [f64],
        a: R,
        hp: R,
        inv: R,
        w2: f64,
        sums: &mut [f64],
        modified: Option<(&[f64], &[f64], &mut [f64])>,
    ) {
        let l = q.len();
        let (d, f, p, a, hp, inv, sums) = (
            &mut d[..l],
            &f[..l],
            &mut p[..l],
            a.fit(l),
            hp.fit(l),
            inv.fit(l),
            &mut sums[..l],
        );
        for b in 0..l {
            let next = d[b] - a.at(b) * q[b] + hp.at(b) * f[b];
            p[b] = (next + d[b]) * inv.at(b);
            sums[b] += 0.5 * (p[b] * p[b] + w2 * (q[b] * q[b]));
            d[b] = next;
        }
        if let Some((mp, mq, modi)) = modified {
            let (mp, mq, modi) = (&mp[..l], &mq[..l], &mut modi[..l]);
            for b in 0..l {
                modi[b] += 0.5 * (mp[b] * (p[b] * p[b]) + mq[b] * (q[b] * q[b]));
            }
        }
    }

    /// One coordinate row of the sweep, for the coefficient rows `a`, `hp`, `inv`.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub fn row<R: Row>(
        mode: Mode,
        q: &mut [f64],
        d: &mut [f64],
        f: &[f64],
        p: &mut [f64],
        (a, hp, inv): (R, R, R),
        w2: f64,
        sums: &mut [f64],
        modified: Option<(&[f64], &[f64], &mut [f64])>,
    ) {
        match mode {
            Mode::Advance => advance(q, d, f, a, hp),
            Mode::AdvanceAndSum => advance_and_sum(q, d, f, a, hp, sums),
            Mode::Track => observe_and_advance(q, d, f, a, hp, inv, w2, sums, modified),
            Mode::Sample => observe(q, d, f, p, a, hp, inv, w2, sums, modified),
        }
    }

    /// What a step's sweep does.
    #[derive(Clone, Copy, PartialEq, Eq)]
    pub enum Mode {
        Advance,
        AdvanceAndSum,
        Track,
        Sample,
    }
}

/// (high, low, blocks high, blocks low) of one lane.
type Extremes = (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>);

/// The streaming recorder of [`crate::energy::Recorder`] for a block of lanes, in the same
/// arithmetic per lane. Running extremes are stored channel-major so that their updates run
/// across lanes without branches; a lane that blows up has its extremes frozen in a snapshot.
struct LaneRecorder<'a> {
    layout: &'a EnergyLayout,
    lanes: usize,
    track: bool,
    save_every: Option<u64>,
    n_steps: Vec<u64>,
    several_blocks: bool,
    plain_modified: bool,
    alive: Vec<bool>,
    dead: usize,
    newly_dead: Vec<usize>,
    energies_this_step: bool,
    steps_done: Vec<u64>,
    status: Vec<Status>,
    /// high[c * lanes + b], low[…]: the four main channels
    high: Vec<f64>,
    low: Vec<f64>,
    blocks_high: Vec<Vec<f64>>,
    blocks_low: Vec<Vec<f64>>,
    /// The extremes of a lane at its blow-up
    frozen: Vec<Option<Extremes>>,
    initial: Vec<Vec<f64>>,
    samples: Vec<Samples>,
    // scratch, one entry per lane
    oscillatory: Vec<f64>,
    kinetic_slow: Vec<f64>,
    modified: Vec<f64>,
    total: Vec<f64>,
    slow_energy: Vec<f64>,
    position_sum: Vec<f64>,
}

impl<'a> LaneRecorder<'a> {
    fn new(
        layout: &'a EnergyLayout,
        lanes: usize,
        spec: &BatchSpec,
        n_steps: &[u64],
        plain_modified: bool,
    ) -> Self {
        let l = layout.n_blocks;
        LaneRecorder {
            plain_modified,
            layout,
            lanes,
            track: spec.track_energies,
            save_every: spec.save_every,
            n_steps: n_steps.to_vec(),
            several_blocks: l > 1,
            alive: vec![true; lanes],
            dead: 0,
            newly_dead: Vec::new(),
            energies_this_step: true,
            steps_done: vec![0; lanes],
            status: vec![Status::Completed; lanes],
            high: vec![f64::NEG_INFINITY; FIRST_BLOCK * lanes],
            low: vec![f64::INFINITY; FIRST_BLOCK * lanes],
            blocks_high: vec![vec![f64::NEG_INFINITY; l]; lanes],
            blocks_low: vec![vec![f64::INFINITY; l]; lanes],
            frozen: vec![None; lanes],
            initial: vec![vec![f64::NAN; layout.n_channels()]; lanes],
            samples: vec![Samples::default(); lanes],
            oscillatory: vec![0.0; lanes],
            kinetic_slow: vec![0.0; lanes],
            modified: vec![0.0; lanes],
            total: vec![0.0; lanes],
            slow_energy: vec![0.0; lanes],
            position_sum: vec![0.0; lanes],
        }
    }

    /// Whether some lane records a sample at `step` (`n_steps` is sorted).
    fn is_sample_step(&self, step: u64) -> bool {
        step == 0
            || self.save_every.is_some_and(|s| step % s == 0)
            || self.n_steps.binary_search(&step).is_ok()
    }

    fn needs_potential_at(&self, step: u64) -> bool {
        self.track || self.is_sample_step(step)
    }

    /// Clears the per-lane sums of this step.
    fn start_step(&mut self, energies: bool, check: bool) {
        self.newly_dead.clear();
        self.energies_this_step = energies;
        if energies {
            self.oscillatory.fill(0.0);
            self.kinetic_slow.fill(0.0);
            self.modified.fill(0.0);
        } else if check {
            self.position_sum.fill(0.0);
        }
    }

    /// The per-lane sums of H_ω, the slow kinetic energy and H*, and Σ q_i (whose finiteness
    /// checks the untracked steps), filled row by row.
    fn accumulators(&mut self) -> (&mut [f64], &mut [f64], &mut [f64], &mut [f64]) {
        let l = self.lanes;
        (
            &mut self.oscillatory[..l],
            &mut self.kinetic_slow[..l],
            &mut self.modified[..l],
            &mut self.position_sum[..l],
        )
    }

    /// The lane sums for a state given whole (step 0).
    fn energies<P: Potential>(&mut self, blk: &Block<P>, q: &[f64], p: &[f64]) {
        self.start_step(true, true);
        let lanes = self.lanes;
        for i in 0..blk.n {
            let (w2, fast, slow) = (self.layout.omega2[i], blk.fast[i], blk.slow[i]);
            for b in 0..lanes {
                let j = i * lanes + b;
                let (pp, qq) = (p[j] * p[j], q[j] * q[j]);
                let e = 0.5 * (pp + w2 * qq);
                self.oscillatory[b] += fast * e;
                self.kinetic_slow[b] += slow * e;
                self.modified[b] += 0.5 * (blk.modified_p[j] * pp + blk.modified_q[j] * qq);
            }
        }
    }

    /// Whether step `step` needs the whole state: samples, or the per-block sums for ℓ > 1.
    fn needs_state(&self, step: u64, first: usize) -> bool {
        let sampling_step = step == 0 || self.save_every.is_some_and(|s| step % s == 0);
        let someone_ends = first < self.lanes && self.n_steps[first] == step;
        sampling_step || someone_ends || (self.track && self.several_blocks)
    }

    /// Totals, finiteness and running extremes of the active lanes from the sums of this step.
    #[inline(always)]
    fn observe_lanes(&mut self, step: u64, u: &[f64], first: usize) {
        let lanes = self.lanes;
        let w = lanes - first;
        if self.energies_this_step {
            let (osc, kin, ur) = (
                &self.oscillatory[first..],
                &self.kinetic_slow[first..],
                &u[first..],
            );
            let (tot, slw) = (&mut self.total[first..], &mut self.slow_energy[first..]);
            let mut bad = 0u64;
            for b in 0..w {
                slw[b] = kin[b] + ur[b];
                tot[b] = osc[b] + slw[b];
                bad |= u64::from(!tot[b].is_finite());
            }
            if bad != 0 {
                self.find_blow_ups(first);
            }
            if self.track {
                let modified = if self.plain_modified {
                    &self.oscillatory
                } else {
                    &self.modified
                };
                let channels: [&[f64]; FIRST_BLOCK] = [
                    &self.total[first..],
                    &self.oscillatory[first..],
                    &self.slow_energy[first..],
                    &modified[first..],
                ];
                for (c, e) in channels.iter().enumerate() {
                    let (hi, lo) = (
                        &mut self.high[c * lanes + first..(c + 1) * lanes],
                        &mut self.low[c * lanes + first..(c + 1) * lanes],
                    );
                    let e = &e[..w];
                    for b in 0..w {
                        hi[b] = if e[b] > hi[b] { e[b] } else { hi[b] };
                        lo[b] = if e[b] < lo[b] { e[b] } else { lo[b] };
                    }
                }
            }
        } else {
            let sums = &self.position_sum[first..];
            let mut bad = 0u64;
            for &x in sums {
                bad |= u64::from(!x.is_finite());
            }
            if bad != 0 {
                for b in first..lanes {
                    if self.alive[b] && !self.position_sum[b].is_finite() {
                        self.die(b);
                    }
                }
            }
        }
        if self.dead > 0 {
            for b in first..lanes {
                if self.alive[b] {
                    self.steps_done[b] = step;
                }
            }
        } else {
            self.steps_done[first..].fill(step);
        }
    }

    /// As [`observe_lanes`](Self::observe_lanes), then the per-block extremes and the samples.
    fn observe<P: Potential>(
        &mut self,
        blk: &Block<P>,
        step: u64,
        q: &[f64],
        p: &[f64],
        u: &[f64],
        first: usize,
    ) {
        self.observe_lanes(step, u, first);
        if !self.energies_this_step {
            return;
        }
        let lanes = self.lanes;
        if self.track && self.several_blocks {
            for b in first..lanes {
                if !self.alive[b] {
                    continue;
                }
                let blocks = self.block_sums(q, p, b);
                for (j, &e) in blocks.iter().enumerate().skip(1) {
                    self.blocks_high[b][j - 1] = self.blocks_high[b][j - 1].max(e);
                    self.blocks_low[b][j - 1] = self.blocks_low[b][j - 1].min(e);
                }
            }
        }
        let sampling_step = step == 0 || self.save_every.is_some_and(|s| step % s == 0);
        for b in first..lanes {
            if self.alive[b] && (sampling_step || step == self.n_steps[b]) {
                self.sample(blk, b, step, q, p);
            }
        }
    }

    /// The lanes whose total energy is not finite at `step` blow up.
    #[cold]
    fn find_blow_ups(&mut self, first: usize) {
        for b in first..self.lanes {
            if self.alive[b] && !self.total[b].is_finite() {
                self.die(b);
            }
        }
    }

    fn die(&mut self, b: usize) {
        let lanes = self.lanes;
        let pick = |v: &[f64]| {
            (0..FIRST_BLOCK)
                .map(|c| v[c * lanes + b])
                .collect::<Vec<f64>>()
        };
        self.frozen[b] = Some((
            pick(&self.high),
            pick(&self.low),
            self.blocks_high[b].clone(),
            self.blocks_low[b].clone(),
        ));
        self.alive[b] = false;
        self.dead += 1;
        self.status[b] = Status::BlowUp;
        self.newly_dead.push(b);
    }

    #[cold]
    fn sample<P: Potential>(&mut self, blk: &Block<P>, b: usize, step: u64, q: &[f64], p: &[f64]) {
        let (n, lanes) = (blk.n, self.lanes);
        let modified = if self.plain_modified {
            self.oscillatory[b]
        } else {
            self.modified[b]
        };
        let mut row = vec![
            self.total[b],
            self.oscillatory[b],
            self.slow_energy[b],
            modified,
        ];
        if self.several_blocks {
            row.extend_from_slice(&self.block_sums(q, p, b)[1..]);
        } else if self.layout.n_blocks == 1 {
            row.push(self.oscillatory[b]);
        }
        if step == 0 {
            self.initial[b] = row.clone();
        }
        let s = &mut self.samples[b];
        s.steps.push(step);
        s.q.extend((0..n).map(|i| q[i * lanes + b]));
        s.p.extend((0..n).map(|i| p[i * lanes + b]));
        s.energies.extend_from_slice(&row);
    }

    /// I_1 … I_ℓ of lane b (index 0 holds the slow kinetic part), as the scalar recorder sums them.
    fn block_sums(&self, q: &[f64], p: &[f64], b: usize) -> Vec<f64> {
        let lanes = self.lanes;
        let mut blocks = vec![0.0; self.layout.n_blocks + 1];
        for (i, &j) in self.layout.block.iter().enumerate() {
            let (qi, pi) = (q[i * lanes + b], p[i * lanes + b]);
            blocks[j] += 0.5 * (pi * pi + self.layout.omega2[i] * (qi * qi));
        }
        blocks
    }

    fn interrupt(&mut self, step: u64) {
        for b in 0..self.lanes {
            if self.alive[b] && self.n_steps[b] > step {
                self.status[b] = Status::Interrupted;
            }
        }
    }

    fn finish(self) -> Vec<TrajectoryOutput> {
        let lanes = self.lanes;
        (0..lanes)
            .map(|b| {
                let (mut high, mut low, bh, bl) = match &self.frozen[b] {
                    Some(f) => f.clone(),
                    None => {
                        let pick = |v: &[f64]| {
                            (0..FIRST_BLOCK)
                                .map(|c| v[c * lanes + b])
                                .collect::<Vec<f64>>()
                        };
                        (
                            pick(&self.high),
                            pick(&self.low),
                            self.blocks_high[b].clone(),
                            self.blocks_low[b].clone(),
                        )
                    }
                };
                if self.several_blocks {
                    high.extend_from_slice(&bh);
                    low.extend_from_slice(&bl);
                } else if self.layout.n_blocks == 1 {
                    high.push(high[OSCILLATORY]);
                    low.push(low[OSCILLATORY]);
                }
                let e0 = &self.initial[b];
                let max_deviation = if self.track {
                    e0.iter()
                        .zip(high.iter().zip(&low))
                        .map(|(&e, (&hi, &lo))| (hi - e).max(e - lo))
                        .collect()
                } else {
                    vec![f64::NAN; e0.len()]
                };
                TrajectoryOutput {
                    status: self.status[b],
                    steps_done: self.steps_done[b],
                    initial_energies: e0.clone(),
                    max_deviation,
                    samples: self.samples[b].clone(),
                }
            })
            .collect()
    }
}

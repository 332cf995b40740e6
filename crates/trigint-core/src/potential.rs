//! Potentials U(q) with their forces g(q) = -∇U(q).
//!
//! The stepping kernels are generic over [`Potential`], so a native potential is
//! inlined into the loop. Forces are written as `f = -∇U` because that is what the
//! recursions consume.

use crate::error::{CoreError, CoreResult};

/// A potential U: ℝⁿ → ℝ together with its force g = −∇U.
pub trait Potential: Sync {
    /// Number of coordinates the potential acts on.
    fn dim(&self) -> usize;

    /// U(x).
    fn value(&self, x: &[f64]) -> CoreResult<f64>;

    /// Writes g(x) = −∇U(x) into `f` (same length as `x`).
    fn force(&self, x: &[f64], f: &mut [f64]) -> CoreResult<()>;

    /// U(x) and g(x) in one pass; potentials override it when the two share work.
    #[inline]
    fn value_and_force(&self, x: &[f64], f: &mut [f64]) -> CoreResult<f64> {
        self.force(x, f)?;
        self.value(x)
    }

    /// Forces (and, with `values`, U) for `lanes` states stored coordinate-major,
    /// x[i * lanes + b] for coordinate i of lane b. The default gathers each lane and calls the
    /// one-state methods, so the numbers are those of [`value_and_force`](Self::value_and_force)
    /// bit for bit; native potentials override it with loops that vectorize across lanes and
    /// must keep the same operations in the same order.
    ///
    /// `values` always has one entry per lane; it is written only when `with_value`, though a
    /// potential may fill it anyway when the value comes for free.
    fn force_lanes(
        &self,
        x: &[f64],
        f: &mut [f64],
        values: &mut [f64],
        with_value: bool,
        lanes: usize,
    ) -> CoreResult<()> {
        let n = x.len() / lanes;
        let (mut xs, mut fs) = (vec![0.0; n], vec![0.0; n]);
        for b in 0..lanes {
            for i in 0..n {
                xs[i] = x[i * lanes + b];
            }
            if with_value {
                values[b] = self.value_and_force(&xs, &mut fs)?;
            } else {
                self.force(&xs, &mut fs)?;
            }
            for i in 0..n {
                f[i * lanes + b] = fs[i];
            }
        }
        Ok(())
    }

    /// U for `lanes` states stored coordinate-major (see [`force_lanes`](Self::force_lanes)).
    fn value_lanes(&self, x: &[f64], values: &mut [f64], lanes: usize) -> CoreResult<()> {
        let n = x.len() / lanes;
        let mut xs = vec![0.0; n];
        for b in 0..lanes {
            for i in 0..n {
                xs[i] = x[i * lanes + b];
            }
            values[b] = self.value(&xs)?;
        }
        Ok(())
    }

    /// Checks that `n` coordinates fit this potential.
    fn check_dim(&self, n: usize) -> CoreResult<()> {
        if n == self.dim() {
            Ok(())
        } else {
            Err(CoreError::DimensionMismatch {
                expected: self.dim(),
                got: n,
            })
        }
    }
}

/// The Fermi–Pasta–Ulam problem with alternating stiff and soft springs in the
/// variables x = (x₀,₁ … x₀,ₘ, x₁,₁ … x₁,ₘ) [Hairer–Lubich–Wanner, GNI §I.5]:
///
/// U(x) = ¼ [ (x₀,₁ − x₁,₁)⁴ + Σᵢ₌₁^{m−1} (x₀,ᵢ₊₁ − x₁,ᵢ₊₁ − x₀,ᵢ − x₁,ᵢ)⁴ + (x₀,ₘ + x₁,ₘ)⁴ ].
///
/// The first m coordinates are slow (ω = 0), the last m carry the stiff frequency.
#[derive(Debug, Clone, Copy)]
pub struct Fpu {
    pub m: usize,
}

impl Fpu {
    pub fn new(m: usize) -> CoreResult<Self> {
        if m == 0 {
            return Err(CoreError::invalid(
                "m",
                "the FPU chain needs m >= 1 stiff springs",
            ));
        }
        Ok(Fpu { m })
    }

    /// g = −∇U into `f`, returning U. Written out spring by spring (no closures, no branches)
    /// and with `m` taken from the slice length, so a fixed-size state unrolls completely.
    /// Long chains go through [`Fpu::accumulate_force_long`], which gives the same bits.
    #[inline(always)]
    fn accumulate_force(x: &[f64], f: &mut [f64]) -> f64 {
        let m = x.len() / 2;
        if m > 16 {
            return Self::accumulate_force_long::<true>(x, f);
        }
        let (x0, x1) = x.split_at(m);
        let (f0, f1) = f.split_at_mut(m);
        let (x0, x1, f0, f1) = (&x0[..m], &x1[..m], &mut f0[..m], &mut f1[..m]);
        // Spring 0 joins the wall to the first stiff spring: d = x₀,₁ − x₁,₁.
        let d = x0[0] - x1[0];
        let d3 = d * d * d;
        let mut value = 0.25 * (d3 * d);
        f0[0] = -d3;
        f1[0] = d3;
        for i in 1..m {
            // Spring i: d = x₀,ᵢ₊₁ − x₁,ᵢ₊₁ − x₀,ᵢ − x₁,ᵢ (0-based: i and i − 1).
            let d = x0[i] - x1[i] - x0[i - 1] - x1[i - 1];
            let d3 = d * d * d;
            value += 0.25 * (d3 * d);
            f0[i - 1] += d3;
            f1[i - 1] += d3;
            f0[i] = -d3;
            f1[i] = d3;
        }
        // Spring m joins the last stiff spring to the wall: d = x₀,ₘ + x₁,ₘ.
        let d = x0[m - 1] + x1[m - 1];
        let d3 = d * d * d;
        value += 0.25 * (d3 * d);
        f0[m - 1] -= d3;
        f1[m - 1] -= d3;
        value
    }

    /// The same numbers for long chains, in vectorizable passes over stretches of springs:
    /// the elongations d and cubes d³ of the springs, then the forces g₀,ᵢ = (−d³ᵢ) + d³ᵢ₊₁ and
    /// g₁,ᵢ = d³ᵢ + d³ᵢ₊₁ (g₀,ₘ = (−d³ₘ) − d³ₘ₊₁, g₁,ₘ = d³ₘ − d³ₘ₊₁ at the end): the operations
    /// of the single pass, so the same bits. U is summed spring by spring in the same order.
    #[inline(always)]
    fn accumulate_force_long<const VALUE: bool>(x: &[f64], f: &mut [f64]) -> f64 {
        const STRETCH: usize = 64;
        let m = x.len() / 2;
        let (x0, x1) = x.split_at(m);
        let (f0, f1) = f.split_at_mut(m);
        let (mut ds, mut cubes) = ([0.0f64; STRETCH + 1], [0.0f64; STRETCH + 1]);
        // Slot 0 of a stretch holds its first spring, carried over from the stretch before.
        ds[0] = x0[0] - x1[0];
        cubes[0] = ds[0] * ds[0] * ds[0];
        let mut value = 0.25 * (cubes[0] * ds[0]);
        let mut start = 0; // springs start ..= end act on coordinates start .. end
        while start < m {
            let end = (start + STRETCH).min(m);
            let inner = end.min(m - 1) - start; // springs start+1 ..= start+inner are inner ones
            {
                let (a, c) = (
                    &x0[start + 1..start + 1 + inner],
                    &x1[start + 1..start + 1 + inner],
                );
                let (ap, cp) = (&x0[start..start + inner], &x1[start..start + inner]);
                let (d, d3) = (&mut ds[1..1 + inner], &mut cubes[1..1 + inner]);
                for j in 0..inner {
                    d[j] = a[j] - c[j] - ap[j] - cp[j];
                    d3[j] = d[j] * d[j] * d[j];
                }
            }
            if end == m {
                let j = m - start;
                ds[j] = x0[m - 1] + x1[m - 1];
                cubes[j] = ds[j] * ds[j] * ds[j];
            }
            let springs = end - start; // springs start+1 ..= end are new here
            if VALUE {
                for j in 1..=springs {
                    value += 0.25 * (cubes[j] * ds[j]);
                }
            }
            let last_inner = if end == m { springs - 1 } else { springs };
            {
                let (g0, g1) = (
                    &mut f0[start..start + last_inner],
                    &mut f1[start..start + last_inner],
                );
                let (now, next) = (&cubes[..last_inner], &cubes[1..1 + last_inner]);
                for j in 0..last_inner {
                    g0[j] = -now[j] + next[j];
                    g1[j] = now[j] + next[j];
                }
            }
            if end == m {
                let (c, c_end) = (cubes[springs - 1], cubes[springs]);
                f0[m - 1] = -c - c_end;
                f1[m - 1] = c - c_end;
            }
            ds[0] = ds[springs];
            cubes[0] = cubes[springs];
            start = end;
        }
        value
    }
}

impl Potential for Fpu {
    fn dim(&self) -> usize {
        2 * self.m
    }

    #[inline]
    fn value(&self, x: &[f64]) -> CoreResult<f64> {
        let m = x.len() / 2;
        let (x0, x1) = x.split_at(m);
        let quartic = |d: f64| 0.25 * (d * d * d * d);
        let mut value = quartic(x0[0] - x1[0]);
        for i in 1..m {
            value += quartic(x0[i] - x1[i] - x0[i - 1] - x1[i - 1]);
        }
        Ok(value + quartic(x0[m - 1] + x1[m - 1]))
    }

    #[inline]
    fn force(&self, x: &[f64], f: &mut [f64]) -> CoreResult<()> {
        if x.len() / 2 > 16 {
            Self::accumulate_force_long::<false>(x, f);
        } else {
            Self::accumulate_force(x, f);
        }
        Ok(())
    }

    #[inline]
    fn value_and_force(&self, x: &[f64], f: &mut [f64]) -> CoreResult<f64> {
        Ok(Self::accumulate_force(x, f))
    }

    /// The loop of [`Fpu::accumulate_force`] with every scalar turned into a row of lanes:
    /// the same operations in the same order, so each lane gets the one-state bits.
    #[inline(always)]
    fn force_lanes(
        &self,
        x: &[f64],
        f: &mut [f64],
        values: &mut [f64],
        with_value: bool,
        lanes: usize,
    ) -> CoreResult<()> {
        if with_value {
            self.lanes::<true>(x, f, values, lanes);
        } else {
            self.lanes::<false>(x, f, values, lanes);
        }
        Ok(())
    }
}

impl Fpu {
    /// [`Potential::force_lanes`] for FPU, with or without U.
    #[inline(always)]
    fn lanes<const VALUE: bool>(&self, x: &[f64], f: &mut [f64], values: &mut [f64], lanes: usize) {
        let m = self.m;
        let (x0, x1) = x.split_at(m * lanes);
        let (f0, f1) = f.split_at_mut(m * lanes);
        let value = &mut values[..lanes];
        fpu_lanes::first_spring::<VALUE>(
            &x0[..lanes],
            &x1[..lanes],
            &mut f0[..lanes],
            &mut f1[..lanes],
            value,
        );
        for i in 1..m {
            let (a, c) = (
                &x0[i * lanes..(i + 1) * lanes],
                &x1[i * lanes..(i + 1) * lanes],
            );
            let (ap, cp) = (
                &x0[(i - 1) * lanes..i * lanes],
                &x1[(i - 1) * lanes..i * lanes],
            );
            let (f0p, f0i) = f0[(i - 1) * lanes..(i + 1) * lanes].split_at_mut(lanes);
            let (f1p, f1i) = f1[(i - 1) * lanes..(i + 1) * lanes].split_at_mut(lanes);
            fpu_lanes::middle_spring::<VALUE>(a, c, ap, cp, f0p, f1p, f0i, f1i, value);
        }
        let last = (m - 1) * lanes..m * lanes;
        fpu_lanes::last_spring::<VALUE>(
            &x0[last.clone()],
            &x1[last.clone()],
            &mut f0[last.clone()],
            &mut f1[last],
            value,
        );
    }
}

/// The FPU springs over rows of lanes; every row is its own argument so that the compiler
/// knows they do not overlap and vectorizes across lanes.
mod fpu_lanes {
    #[inline(always)]
    pub fn first_spring<const VALUE: bool>(
        a: &[f64],
        c: &[f64],
        g0: &mut [f64],
        g1: &mut [f64],
        value: &mut [f64],
    ) {
        let l = a.len();
        let (c, g0, g1, value) = (&c[..l], &mut g0[..l], &mut g1[..l], &mut value[..l]);
        for b in 0..l {
            let d = a[b] - c[b];
            let d3 = d * d * d;
            if VALUE {
                value[b] = 0.25 * (d3 * d);
            }
            g0[b] = -d3;
            g1[b] = d3;
        }
    }

    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub fn middle_spring<const VALUE: bool>(
        a: &[f64],
        c: &[f64],
        ap: &[f64],
        cp: &[f64],
        f0p: &mut [f64],
        f1p: &mut [f64],
        f0i: &mut [f64],
        f1i: &mut [f64],
        value: &mut [f64],
    ) {
        let l = a.len();
        let (c, ap, cp) = (&c[..l], &ap[..l], &cp[..l]);
        let (f0p, f1p, f0i, f1i, value) = (
            &mut f0p[..l],
            &mut f1p[..l],
            &mut f0i[..l],
            &mut f1i[..l],
            &mut value[..l],
        );
        for b in 0..l {
            let d = a[b] - c[b] - ap[b] - cp[b];
            let d3 = d * d * d;
            if VALUE {
                value[b] += 0.25 * (d3 * d);
            }
            f0p[b] += d3;
            f1p[b] += d3;
            f0i[b] = -d3;
            f1i[b] = d3;
        }
    }

    #[inline(always)]
    pub fn last_spring<const VALUE: bool>(
        a: &[f64],
        c: &[f64],
        g0: &mut [f64],
        g1: &mut [f64],
        value: &mut [f64],
    ) {
        let l = a.len();
        let (c, g0, g1, value) = (&c[..l], &mut g0[..l], &mut g1[..l], &mut value[..l]);
        for b in 0..l {
            let d = a[b] + c[b];
            let d3 = d * d * d;
            if VALUE {
                value[b] += 0.25 * (d3 * d);
            }
            g0[b] -= d3;
            g1[b] -= d3;
        }
    }
}

/// A sparse polynomial U(x) = Σₜ cₜ Πᵢ xᵢ^{eₜᵢ}, stored term by term as lists of
/// (variable, exponent) factors with non-zero exponents.
#[derive(Debug, Clone)]
pub struct Polynomial {
    dim: usize,
    coefficients: Vec<f64>,
    /// Term t's factors are `factors[offsets[t]..offsets[t + 1]]`.
    offsets: Vec<usize>,
    factors: Vec<(usize, i32)>,
}

impl Polynomial {
    /// Builds the polynomial from coefficients (length T) and a dense exponent
    /// matrix in row-major order (T × dim, non-negative integers).
    pub fn new(dim: usize, coefficients: Vec<f64>, exponents: &[i64]) -> CoreResult<Self> {
        if dim == 0 {
            return Err(CoreError::invalid(
                "dim",
                "a polynomial needs at least one variable",
            ));
        }
        if exponents.len() != coefficients.len() * dim {
            return Err(CoreError::invalid(
                "exponents",
                format!(
                    "expected {} x {} exponents, got {} values",
                    coefficients.len(),
                    dim,
                    exponents.len()
                ),
            ));
        }
        if let Some(c) = coefficients.iter().find(|c| !c.is_finite()) {
            return Err(CoreError::invalid(
                "coefficients",
                format!("must be finite, got {c}"),
            ));
        }
        let mut offsets = vec![0];
        let mut factors = Vec::new();
        for row in exponents.chunks(dim) {
            for (var, &e) in row.iter().enumerate() {
                if !(0..=i32::MAX as i64).contains(&e) {
                    return Err(CoreError::invalid(
                        "exponents",
                        format!("must be non-negative integers, got {e}"),
                    ));
                }
                if e > 0 {
                    factors.push((var, e as i32));
                }
            }
            offsets.push(factors.len());
        }
        Ok(Polynomial {
            dim,
            coefficients,
            offsets,
            factors,
        })
    }

    #[inline]
    fn term(&self, t: usize) -> &[(usize, i32)] {
        &self.factors[self.offsets[t]..self.offsets[t + 1]]
    }
}

impl Potential for Polynomial {
    fn dim(&self) -> usize {
        self.dim
    }

    fn value(&self, x: &[f64]) -> CoreResult<f64> {
        let mut value = 0.0;
        for (t, &c) in self.coefficients.iter().enumerate() {
            let product: f64 = self.term(t).iter().map(|&(v, e)| x[v].powi(e)).product();
            value += c * product;
        }
        Ok(value)
    }

    fn force(&self, x: &[f64], f: &mut [f64]) -> CoreResult<()> {
        f.fill(0.0);
        for (t, &c) in self.coefficients.iter().enumerate() {
            let term = self.term(t);
            for (j, &(var, e)) in term.iter().enumerate() {
                // ∂/∂x_var of c Π x^e: the product of the other factors, times e x^(e-1).
                let mut d = c * f64::from(e) * x[var].powi(e - 1);
                for (k, &(v, ek)) in term.iter().enumerate() {
                    if k != j {
                        d *= x[v].powi(ek);
                    }
                }
                f[var] -= d;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn numerical_force<P: Potential>(p: &P, x: &[f64]) -> Vec<f64> {
        let h = 1e-6;
        (0..x.len())
            .map(|i| {
                let (mut a, mut b) = (x.to_vec(), x.to_vec());
                a[i] += h;
                b[i] -= h;
                -(p.value(&a).unwrap() - p.value(&b).unwrap()) / (2.0 * h)
            })
            .collect()
    }

    #[test]
    fn fpu_standard_value() {
        // x01 = 1, x11 = 1/50: U = ((0.98)^4 + (1.02)^4)/4.
        let mut x = vec![0.0; 6];
        x[0] = 1.0;
        x[3] = 0.02;
        let u = Fpu::new(3).unwrap().value(&x).unwrap();
        assert!((u - 0.50120008).abs() < 1e-14, "{u}");
    }

    #[test]
    fn fpu_force_is_minus_gradient() {
        for m in 1..5 {
            let p = Fpu::new(m).unwrap();
            let x: Vec<f64> = (0..2 * m).map(|i| 0.3 * (i as f64 + 1.0).sin()).collect();
            let mut f = vec![0.0; 2 * m];
            let v = p.value_and_force(&x, &mut f).unwrap();
            assert!((v - p.value(&x).unwrap()).abs() < 1e-15);
            for (a, b) in f.iter().zip(numerical_force(&p, &x)) {
                assert!((a - b).abs() < 1e-8, "m={m}: {a} vs {b}");
            }
        }
    }

    #[test]
    fn long_chains_give_the_single_pass_bits() {
        // accumulate_force_long against the single-pass loop written out here, bit for bit.
        for m in [17, 64, 65, 128, 129, 1000] {
            let x: Vec<f64> = (0..2 * m)
                .map(|i| 0.3 * ((i as f64) * 0.37).sin())
                .collect();
            let (x0, x1) = x.split_at(m);
            let (mut f0, mut f1) = (vec![0.0; m], vec![0.0; m]);
            let d = x0[0] - x1[0];
            let d3 = d * d * d;
            let mut value = 0.25 * (d3 * d);
            f0[0] = -d3;
            f1[0] = d3;
            for i in 1..m {
                let d = x0[i] - x1[i] - x0[i - 1] - x1[i - 1];
                let d3 = d * d * d;
                value += 0.25 * (d3 * d);
                f0[i - 1] += d3;
                f1[i - 1] += d3;
                f0[i] = -d3;
                f1[i] = d3;
            }
            let d = x0[m - 1] + x1[m - 1];
            let d3 = d * d * d;
            value += 0.25 * (d3 * d);
            f0[m - 1] -= d3;
            f1[m - 1] -= d3;
            let mut f = vec![0.0; 2 * m];
            let v = Fpu::accumulate_force_long::<true>(&x, &mut f);
            assert_eq!(v.to_bits(), value.to_bits(), "m = {m}");
            assert_eq!(&f[..m], &f0[..], "m = {m}");
            assert_eq!(&f[m..], &f1[..], "m = {m}");
        }
    }

    #[test]
    fn polynomial_matches_hand_written() {
        // U = q0^3 + q0^4 - 2 q0 q1^2 on two variables.
        let p = Polynomial::new(2, vec![1.0, 1.0, -2.0], &[3, 0, 4, 0, 1, 2]).unwrap();
        let x = [0.7, -1.3];
        let u = 0.7f64.powi(3) + 0.7f64.powi(4) - 2.0 * 0.7 * 1.69;
        assert!((p.value(&x).unwrap() - u).abs() < 1e-14);
        let mut f = [0.0; 2];
        p.force(&x, &mut f).unwrap();
        let g0 = 3.0 * 0.49 + 4.0 * 0.343 - 2.0 * 1.69;
        let g1 = -2.0 * 0.7 * 2.0 * -1.3;
        assert!((f[0] + g0).abs() < 1e-14 && (f[1] + g1).abs() < 1e-14);
    }

    #[test]
    fn polynomial_rejects_bad_exponents() {
        assert!(Polynomial::new(2, vec![1.0], &[1]).is_err());
        assert!(Polynomial::new(1, vec![1.0], &[-1]).is_err());
        assert!(Polynomial::new(1, vec![f64::NAN], &[1]).is_err());
    }
}

//! The Fermi–Pasta–Ulam chain with alternating stiff and soft springs, written out in Rust.

use super::linear::optional_map;
use super::{LinearMap, Potential, Scratch};
use crate::description::{FromDescription, Value};
use crate::energy::at;
use crate::error::{CoreError, CoreResult};
use crate::real::Real;
use crate::sum::{pairwise, Sum8};

/// The FPU problem's soft springs in the variables x = (x₀,₁ … x₀,ₘ, x₁,₁ … x₁,ₘ)
/// [Hairer–Lubich–Wanner, GNI §I.5]:
///
/// U(x) = ¼ [ (x₀,₁ − x₁,₁)⁴ + Σᵢ₌₁^{m−1} (x₀,ᵢ₊₁ − x₁,ᵢ₊₁ − x₀,ᵢ − x₁,ᵢ)⁴ + (x₀,ₘ + x₁,ₘ)⁴ ].
///
/// The first m coordinates are slow (ω = 0), the last m carry the stiff frequency.
///
/// With an input map M (2m × n), the potential is U(M z) of coordinates z: the chain in any
/// coordinates an orthogonal change of variables puts it in (the original q₁ … q₂ₘ of GNI I.5,
/// or the eigenvectors of a stiffness matrix), with the force Mᵀ g(M z).
#[derive(Debug, Clone)]
pub struct Fpu {
    pub m: usize,
    pub map: Option<LinearMap>,
}

impl FromDescription for Fpu {
    /// `{"kind": "fpu", "m", "map"?}`.
    fn from_description(d: &Value) -> CoreResult<Self> {
        let m = d.field("m")?.to_usize("m")?;
        match optional_map(d)? {
            Some(map) => Fpu::with_map(m, map),
            None => Fpu::new(m),
        }
    }
}

/// Chains longer than this go through vectorizable passes over the springs.
const SHORT: usize = 16;

impl Fpu {
    pub fn new(m: usize) -> CoreResult<Self> {
        if m == 0 {
            return Err(CoreError::invalid(
                "m",
                "the FPU chain needs m >= 1 stiff springs",
            ));
        }
        Ok(Fpu { m, map: None })
    }

    /// The chain evaluated at x = M z: `map` has 2m rows, one column per coordinate z.
    pub fn with_map(m: usize, map: LinearMap) -> CoreResult<Self> {
        let fpu = Self::new(m)?;
        if map.rows != 2 * m || map.cols == 0 {
            return Err(CoreError::invalid(
                "map",
                format!(
                    "the FPU chain with m = {m} reads 2m = {} variables; the map has {} rows and {} columns",
                    2 * m,
                    map.rows,
                    map.cols
                ),
            ));
        }
        Ok(Fpu {
            map: Some(map),
            ..fpu
        })
    }

    /// The chain at x = M z with the force Mᵀ g(x). Out of line, so that the kernels inline
    /// only the unmapped chain (its fixed-size state stays in registers).
    #[inline(never)]
    fn mapped<L: Real>(
        &self,
        map: &LinearMap,
        z: &[L],
        f: &mut [L],
        with_value: bool,
        ws: &mut FpuWorkspace<L>,
    ) -> L {
        let (mut xs, mut gs) = (std::mem::take(&mut ws.x), std::mem::take(&mut ws.g));
        map.apply(z, &mut xs);
        let u = self.chain(&xs, &mut gs, with_value, ws);
        f.fill(L::zero());
        map.apply_transpose_add(&gs, f);
        (ws.x, ws.g) = (xs, gs);
        u
    }

    #[inline(always)]
    fn chain<L: Real>(
        &self,
        x: &[L],
        f: &mut [L],
        with_value: bool,
        ws: &mut FpuWorkspace<L>,
    ) -> L {
        match (x.len() / 2 > SHORT, with_value) {
            (false, true) => Self::short::<L, true>(x, f),
            (false, false) => Self::short::<L, false>(x, f),
            (true, true) => Self::long::<L, true, true>(x, f, ws),
            (true, false) => Self::long::<L, false, true>(x, f, ws),
        }
    }

    /// g = −∇U into `f`, and U when VALUE. Written out spring by spring (no closures, no
    /// arrays) with `m` taken from the slice length, so a fixed-size state unrolls completely
    /// and stays in registers. U's terms go to eight partial sums: the kernels' pairwise order.
    #[inline(always)]
    fn short<L: Real, const VALUE: bool>(x: &[L], f: &mut [L]) -> L {
        let m = x.len() / 2;
        let (x0, x1) = x.split_at(m);
        let (f0, f1) = f.split_at_mut(m);
        let (x0, x1, f0, f1) = (&x0[..m], &x1[..m], &mut f0[..m], &mut f1[..m]);
        let quarter = L::splat(0.25);
        let mut parts = Sum8::new();
        let mut term = |i: usize, d: L, d3: L| {
            if VALUE {
                parts.add(i % 8, i >= 8, quarter * (d3 * d));
            }
        };
        // Spring 0 joins the wall to the first stiff spring: d = x₀,₁ − x₁,₁.
        let d = x0[0] - x1[0];
        let mut before = d * d * d;
        term(0, d, before);
        for i in 1..m {
            // Spring i: d = (x₀,ᵢ₊₁ − x₁,ᵢ₊₁) − (x₀,ᵢ + x₁,ᵢ) (0-based: i and i − 1), grouped
            // as a tree so that the step's critical path is one addition shorter.
            let d = (x0[i] - x1[i]) - (x0[i - 1] + x1[i - 1]);
            let d3 = d * d * d;
            term(i, d, d3);
            // g₀,ᵢ = −d³ᵢ + d³ᵢ₊₁, with U taken as d³ᵢ₊₁ − d³ᵢ: the same number (a − b is
            // a + (−b), and the sum does not depend on the order). Which form schedules better
            // on 16 registers differs with the loop around it (FPU m = 3, AMD Zen 5): without
            // the negation the AVX2 copy's streamed step took 8.9 ns against 10.6, but the
            // baseline copy's step without energies 7.8 against 7.3.
            f0[i - 1] = if VALUE { d3 - before } else { -before + d3 };
            f1[i - 1] = before + d3;
            before = d3;
        }
        // Spring m joins the last stiff spring to the wall: d = x₀,ₘ + x₁,ₘ.
        let d = x0[m - 1] + x1[m - 1];
        let d3 = d * d * d;
        term(m, d, d3);
        f0[m - 1] = -before - d3;
        f1[m - 1] = before - d3;
        if VALUE {
            parts.total(m + 1)
        } else {
            L::zero()
        }
    }

    /// The same numbers for long chains in vectorizable passes: the elongations d and cubes d³
    /// of all springs, then the forces g₀,ᵢ = (−d³ᵢ) + d³ᵢ₊₁ and g₁,ᵢ = d³ᵢ + d³ᵢ₊₁
    /// (g₀,ₘ = (−d³ₘ) − d³ₘ₊₁, g₁,ₘ = d³ₘ − d³ₘ₊₁ at the end): the operations of the single
    /// pass, so the same forces. U is summed in the kernels' pairwise order (see
    /// [`crate::sum`]), which vectorizes. Without FORCE, U alone (`f` untouched, may be empty).
    #[inline(always)]
    fn long<L: Real, const VALUE: bool, const FORCE: bool>(
        x: &[L],
        f: &mut [L],
        ws: &mut FpuWorkspace<L>,
    ) -> L {
        let m = x.len() / 2;
        let (x0, x1) = x.split_at(m);
        let (ds, cubes) = (&mut ws.d[..m + 1], &mut ws.d3[..m + 1]);
        ds[0] = x0[0] - x1[0];
        {
            let (a, c, ap, cp) = (&x0[1..m], &x1[1..m], &x0[..m - 1], &x1[..m - 1]);
            let d = &mut ds[1..m];
            for j in 0..m - 1 {
                d[j] = (a[j] - c[j]) - (ap[j] + cp[j]);
            }
        }
        ds[m] = x0[m - 1] + x1[m - 1];
        for j in 0..m + 1 {
            cubes[j] = ds[j] * ds[j] * ds[j];
        }
        let mut value = L::zero();
        if VALUE {
            let quarter = L::splat(0.25);
            let (cubes, ds) = (&cubes[..m + 1], &ds[..m + 1]);
            (value, _) = pairwise!(L, 0, m + 1, |j| {
                (quarter * (at(cubes, j) * at(ds, j)), L::zero())
            });
        }
        if !FORCE {
            return value;
        }
        let (f0, f1) = f.split_at_mut(m);
        {
            let (g0, g1) = (&mut f0[..m - 1], &mut f1[..m - 1]);
            let (now, next) = (&cubes[..m - 1], &cubes[1..m]);
            for j in 0..m - 1 {
                g0[j] = -now[j] + next[j];
                g1[j] = now[j] + next[j];
            }
        }
        let (c, c_end) = (cubes[m - 1], cubes[m]);
        f0[m - 1] = -c - c_end;
        f1[m - 1] = c - c_end;
        value
    }
}

impl Fpu {
    /// G(x)v of the chain in its own variables: with the elongations d_i = ℓ_i·x and
    /// e_i = ℓ_i·v, the force's cubes d_i³ become c_i = 3d_i²e_i and are distributed as in the
    /// force (each spring's c computed once and carried to the next coordinate: no buffer, no
    /// call).
    /// `m` is taken from the slice length (as in [`short`](Self::short): a fixed-size state
    /// unrolls completely), for any number type (the tangent's lane loop takes it in `f64`).
    #[inline(always)]
    fn derivative<L: Real>(x: &[L], v: &[L], out: &mut [L]) {
        let m = x.len() / 2;
        let (x0, x1) = x.split_at(m);
        let (v0, v1) = v.split_at(m);
        let (f0, f1) = out.split_at_mut(m);
        let three = L::splat(3.0);
        // Spring 0 joins the wall to the first stiff spring.
        let d = x0[0] - x1[0];
        let mut now = three * d * d * (v0[0] - v1[0]);
        for j in 0..m - 1 {
            let d = (x0[j + 1] - x1[j + 1]) - (x0[j] + x1[j]);
            let e = (v0[j + 1] - v1[j + 1]) - (v0[j] + v1[j]);
            let next = three * d * d * e;
            f0[j] = -now + next;
            f1[j] = now + next;
            now = next;
        }
        // Spring m joins the last stiff spring to the wall.
        let d = x0[m - 1] + x1[m - 1];
        let end = three * d * d * (v0[m - 1] + v1[m - 1]);
        f0[m - 1] = -now - end;
        f1[m - 1] = now - end;
    }
}

/// Elongations and cubes of the springs of a long chain; with a map, x = M z and g(x).
pub struct FpuWorkspace<L> {
    d: Vec<L>,
    d3: Vec<L>,
    x: Vec<L>,
    g: Vec<L>,
}

impl Potential for Fpu {
    type Workspace<L: Real> = FpuWorkspace<L>;
    const INLINE_FORCE: bool = true;

    fn inline_force_ready(&self) -> bool {
        self.map.is_none() && self.m <= SHORT
    }

    #[inline(always)]
    fn inline_force<L: Real>(&self, x: &[L], f: &mut [L], with_value: bool) -> L {
        // `chain` without a map, on a short chain: the same operations.
        if with_value {
            Self::short::<L, true>(x, f)
        } else {
            Self::short::<L, false>(x, f)
        }
    }

    #[inline(always)]
    fn inline_force_derivative<L: Real>(&self, x: &[L], v: &[L], out: &mut [L]) {
        Self::derivative(x, v, out)
    }

    fn dim(&self) -> usize {
        self.map.as_ref().map_or(2 * self.m, |map| map.cols)
    }

    fn workspace<L: Real>(&self) -> FpuWorkspace<L> {
        let springs = if self.m > SHORT { self.m + 1 } else { 0 };
        let mapped = if self.map.is_some() { 2 * self.m } else { 0 };
        FpuWorkspace {
            d: vec![L::zero(); springs],
            d3: vec![L::zero(); springs],
            x: vec![L::zero(); mapped],
            g: vec![L::zero(); mapped],
        }
    }

    #[inline(always)]
    fn force<L: Real>(
        &self,
        x: &[L],
        f: &mut [L],
        with_value: bool,
        ws: &mut FpuWorkspace<L>,
    ) -> CoreResult<L> {
        match &self.map {
            None => Ok(self.chain(x, f, with_value, ws)),
            Some(map) => Ok(self.mapped(map, x, f, with_value, ws)),
        }
    }

    #[inline(always)]
    fn force_derivative(
        &self,
        x: &[f64],
        v: &[f64],
        out: &mut [f64],
        _ws: &mut FpuWorkspace<f64>,
        s: &mut Scratch,
    ) -> CoreResult<()> {
        match &self.map {
            None => Self::derivative(x, v, out),
            Some(map) => {
                // x = M z: G_z v = Mᵀ G(Mz) (M v).
                let n = 2 * self.m;
                let mut xs = std::mem::take(&mut s.a);
                let mut vs = std::mem::take(&mut s.b);
                map.apply(x, Scratch::sized(&mut xs, n));
                map.apply(v, Scratch::sized(&mut vs, n));
                let mut gs = vec![0.0; n];
                Self::derivative(&xs, &vs, &mut gs);
                out.fill(0.0);
                map.apply_transpose_add(&gs, out);
                (s.a, s.b) = (xs, vs);
            }
        }
        Ok(())
    }

    #[inline(always)]
    fn value<L: Real>(&self, x: &[L], ws: &mut FpuWorkspace<L>) -> CoreResult<L> {
        if self.map.is_none() && self.m > SHORT {
            // The long chain's pass up to U, without the forces (which the tracked steps of a
            // filtered method would throw away at every step: FPU m = 1000, one trajectory).
            return Ok(Self::long::<L, true, false>(x, &mut [], ws));
        }
        // The same operations as the force pass with U, the force thrown away.
        let mut f = vec![L::zero(); x.len()];
        self.force(x, &mut f, true, ws)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::real::Lanes;

    pub(crate) fn numerical_force<P: Potential>(p: &P, x: &[f64]) -> Vec<f64> {
        let h = 1e-6;
        let mut ws = p.workspace::<f64>();
        (0..x.len())
            .map(|i| {
                let (mut a, mut b) = (x.to_vec(), x.to_vec());
                a[i] += h;
                b[i] -= h;
                -(p.value(&a, &mut ws).unwrap() - p.value(&b, &mut ws).unwrap()) / (2.0 * h)
            })
            .collect()
    }

    #[test]
    fn standard_value() {
        // x01 = 1, x11 = 1/50: U = ((0.98)^4 + (1.02)^4)/4.
        let mut x = vec![0.0; 6];
        x[0] = 1.0;
        x[3] = 0.02;
        let p = Fpu::new(3).unwrap();
        let u = p.value(&x, &mut p.workspace()).unwrap();
        assert!((u - 0.50120008).abs() < 1e-14, "{u}");
    }

    #[test]
    fn force_is_minus_gradient_and_value_agrees() {
        for m in [1, 2, 3, 5, 17, 40] {
            let p = Fpu::new(m).unwrap();
            let mut ws = p.workspace();
            let x: Vec<f64> = (0..2 * m).map(|i| 0.3 * (i as f64 + 1.0).sin()).collect();
            let mut f = vec![0.0; 2 * m];
            let v = p.force(&x, &mut f, true, &mut ws).unwrap();
            // `value` of a long chain skips the forces: the same operations up to U.
            assert_eq!(
                v.to_bits(),
                p.value(&x, &mut ws).unwrap().to_bits(),
                "m={m}"
            );
            for (a, b) in f.iter().zip(numerical_force(&p, &x)) {
                assert!((a - b).abs() < 1e-8, "m={m}: {a} vs {b}");
            }
        }
    }

    #[test]
    fn long_chains_give_the_single_pass_bits() {
        for m in [17, 64, 65, 1000] {
            let x: Vec<f64> = (0..2 * m)
                .map(|i| 0.3 * ((i as f64) * 0.37).sin())
                .collect();
            let (mut short, mut long) = (vec![0.0; 2 * m], vec![0.0; 2 * m]);
            let v1 = Fpu::short::<f64, true>(&x, &mut short);
            let mut ws = Fpu::new(m).unwrap().workspace();
            let v2 = Fpu::long::<f64, true, true>(&x, &mut long, &mut ws);
            assert_eq!(v1.to_bits(), v2.to_bits(), "m = {m}");
            assert_eq!(short, long, "m = {m}");
        }
    }

    #[test]
    fn a_map_evaluates_the_chain_at_m_z_with_the_force_m_transpose_g() {
        // M: a rotation by 30 degrees in the (0, 4) plane of m = 3, and a sign flip of 2.
        let (c, s) = (0.75f64.sqrt(), 0.5);
        let mut dense = [[0.0; 6]; 6];
        for (i, row) in dense.iter_mut().enumerate() {
            row[i] = 1.0;
        }
        (dense[0][0], dense[0][4], dense[4][0], dense[4][4]) = (c, -s, s, c);
        dense[2][2] = -1.0;
        let (mut ptr, mut idx, mut vals) = (vec![0], vec![], vec![]);
        for row in &dense {
            for (j, &v) in row.iter().enumerate() {
                if v != 0.0 {
                    idx.push(j);
                    vals.push(v);
                }
            }
            ptr.push(idx.len());
        }
        let map = LinearMap::from_csr(6, 6, &ptr, &idx, &vals).unwrap();
        let (plain, mapped) = (Fpu::new(3).unwrap(), Fpu::with_map(3, map).unwrap());
        let z: Vec<f64> = (0..6).map(|i| 0.4 * (i as f64 + 0.5).cos()).collect();
        let x: Vec<f64> = (0..6)
            .map(|i| (0..6).map(|j| dense[i][j] * z[j]).sum())
            .collect();
        let (mut gx, mut gz) = (vec![0.0; 6], vec![0.0; 6]);
        let ux = plain
            .force(&x, &mut gx, true, &mut plain.workspace())
            .unwrap();
        let uz = mapped
            .force(&z, &mut gz, true, &mut mapped.workspace())
            .unwrap();
        assert!((ux - uz).abs() < 1e-15 * ux.abs(), "{ux} vs {uz}");
        for j in 0..6 {
            let want: f64 = (0..6).map(|i| dense[i][j] * gx[i]).sum();
            assert!(
                (gz[j] - want).abs() < 1e-14,
                "coordinate {j}: {} vs {want}",
                gz[j]
            );
        }
        assert!(Fpu::with_map(2, LinearMap::from_csr(6, 6, &ptr, &idx, &vals).unwrap()).is_err());
    }

    #[test]
    fn lanes_give_each_trajectory_its_bits() {
        let p = Fpu::new(3).unwrap();
        let xs: Vec<Vec<f64>> = (0..8)
            .map(|b| (0..6).map(|i| ((b * 6 + i) as f64 * 0.7).cos()).collect())
            .collect();
        let x: Vec<Lanes<8>> = (0..6)
            .map(|i| Lanes(std::array::from_fn(|b| xs[b][i])))
            .collect();
        let mut f = vec![Lanes::<8>::zero(); 6];
        let v = p.force(&x, &mut f, true, &mut p.workspace()).unwrap();
        for b in 0..8 {
            let mut g = vec![0.0; 6];
            let u = p.force(&xs[b], &mut g, true, &mut p.workspace()).unwrap();
            assert_eq!(v.0[b].to_bits(), u.to_bits());
            for i in 0..6 {
                assert_eq!(f[i].0[b].to_bits(), g[i].to_bits());
            }
        }
    }
}

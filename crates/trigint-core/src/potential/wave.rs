//! The nonlinearity of a semilinear wave equation in real Fourier coordinates:
//! U(q) = mean_x V(u) with u = S q on the grid ([`Spectral`]), and
//! g(q) = −∇U(q) = −(1/N) Sᵀ V'(u): one transform to the grid, V and V' pointwise (a compiled
//! one-variable program over all grid points), one transform back.
//!
//! Lanes are stepped one after the other through the same f64 code, so a trajectory has the
//! same bits alone and in a bundle.

use std::sync::{Arc, Mutex};

use super::compiled::{Program, ProgramSpec};
use super::{Potential, Scratch};
use crate::description::{FromDescription, Value};
use crate::error::{CoreError, CoreResult};
use crate::real::Real;
use crate::spectral::{Spectral, SpectralWorkspace};

/// Grid points per tile of the interpreted evaluation of V.
const TILE: usize = 128;

/// U(q) = mean_x V((S q)(x)) on a periodic grid.
#[derive(Debug)]
pub struct Wave {
    grid: Arc<Spectral>,
    v: Program,
    /// Kernel coordinate k is Fourier coordinate `order[k]` of [`Spectral::slots`].
    order: Vec<usize>,
    /// `order` is the identity (a problem ordered as the grid's coordinates): plain copies.
    identity: bool,
    /// The workspace of the last run, kept for the next (runs that overlap make their own):
    /// 2.5 MB on 2¹⁶ points, zeroed anew by every call otherwise. Every buffer of it is written
    /// before it is read (the transforms' outputs, V over all points, the gather of a whole
    /// lane; the interpreter's registers hold the program's constants and what each tile
    /// writes), so what an earlier run left in it changes no bit.
    kept: Kept,
}

/// A [`Wave`]'s kept workspace.
#[derive(Default)]
struct Kept(Arc<Mutex<Option<WaveWorkspace>>>);

impl std::fmt::Debug for Kept {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Kept")
    }
}

#[derive(Default)]
pub struct WaveWorkspace {
    /// One lane's Fourier coordinates (unused when the kernel's state is read in place).
    fourier: Vec<f64>,
    grid: GridWorkspace,
    /// Where it goes back when dropped (None: nowhere, or it is the kept one).
    home: Option<Arc<Mutex<Option<WaveWorkspace>>>>,
}

impl Drop for WaveWorkspace {
    fn drop(&mut self) {
        let Some(home) = self.home.take() else {
            return;
        };
        let back = WaveWorkspace {
            fourier: std::mem::take(&mut self.fourier),
            grid: std::mem::take(&mut self.grid),
            home: None,
        };
        let Ok(mut kept) = home.lock() else {
            return;
        };
        if kept.is_none() {
            *kept = Some(back);
        }
    }
}

/// The grid values and transform scratch of one evaluation.
#[derive(Default)]
struct GridWorkspace {
    u: Vec<f64>,
    g: Vec<f64>,
    values: Vec<f64>,
    registers: Vec<Vec<f64>>,
    fft: SpectralWorkspace,
}

impl FromDescription for Wave {
    /// `{"kind": "wave", "shape", "v": tape, "order"}`.
    fn from_description(d: &Value) -> CoreResult<Self> {
        Wave::new(
            &d.field("shape")?.to_usizes("shape")?,
            &ProgramSpec::from_description(d.field("v")?.to_dict("v")?)?,
            d.field("order")?.to_usizes("order")?,
        )
    }
}

impl Wave {
    /// V from a one-variable tape on a grid of `shape`; the kernel's coordinates are the
    /// Fourier coordinates in `order` (a permutation of 0 … N−1).
    pub fn new(shape: &[usize], v: &ProgramSpec, order: Vec<usize>) -> CoreResult<Self> {
        if v.n_inputs != 1 {
            return Err(CoreError::invalid(
                "wave",
                format!("V must be a function of u alone, got {} inputs", v.n_inputs),
            ));
        }
        let grid = Spectral::shared(shape)?;
        let n = grid.points();
        let mut seen = vec![false; n];
        if order.len() != n
            || !order
                .iter()
                .all(|&i| i < n && !std::mem::replace(&mut seen[i], true))
        {
            return Err(CoreError::invalid(
                "wave",
                format!("order must be a permutation of 0..{n}"),
            ));
        }
        Ok(Wave {
            v: Program::new(v, None)?,
            grid,
            identity: order.iter().enumerate().all(|(k, &i)| k == i),
            order,
            kept: Kept::default(),
        })
    }

    /// A new workspace, with a Fourier buffer of `fourier` numbers.
    fn new_workspace(&self, fourier: usize) -> WaveWorkspace {
        let n = self.grid.points();
        WaveWorkspace {
            fourier: vec![0.0; fourier],
            grid: GridWorkspace {
                u: vec![0.0; n],
                g: vec![0.0; n],
                values: vec![0.0; n],
                registers: self.v.tile_registers::<f64>(TILE),
                fft: self.grid.workspace(),
            },
            home: None,
        }
    }

    pub fn grid(&self) -> &Spectral {
        &self.grid
    }

    /// The state's coordinates as one flat f64 slice, read in place: one lane in the grid's
    /// order.
    fn in_place<'a, L: Real>(&self, x: &'a [L]) -> Option<&'a [f64]> {
        if L::LANES == 1 && self.identity {
            L::as_f64s(x)
        } else {
            None
        }
    }

    /// Lane b of the kernel's state into the Fourier buffer.
    fn gather<L: Real>(&self, x: &[L], b: usize, fourier: &mut [f64]) {
        for (k, &i) in self.order.iter().enumerate() {
            fourier[i] = x[k].lane(b);
        }
    }

    /// U of one trajectory whose Fourier coordinates are `q`; −V' on the grid into `ws.g`
    /// when `force`.
    fn on_grid(&self, q: &[f64], force: bool, with_value: bool, ws: &mut GridWorkspace) -> f64 {
        self.grid.to_grid(q, &mut ws.u, &mut ws.fft);
        let g = if force { Some(&mut ws.g[..]) } else { None };
        let total = self.v.eval_tiles(
            &ws.u,
            g,
            with_value,
            &mut ws.registers,
            &mut ws.values,
            TILE,
        );
        total / self.grid.points() as f64
    }

    /// U of lane b of the state (its coordinates read in place where they can be).
    fn lane_on_grid<L: Real>(
        &self,
        x: &[L],
        b: usize,
        force: bool,
        with_value: bool,
        ws: &mut WaveWorkspace,
    ) -> f64 {
        match self.in_place(x) {
            Some(q) => self.on_grid(q, force, with_value, &mut ws.grid),
            None => {
                self.gather(x, b, &mut ws.fourier);
                self.on_grid(&ws.fourier, force, with_value, &mut ws.grid)
            }
        }
    }

    /// G(x)v (see [`Potential::force_derivative`]), from u = S x where it is `known`. The state's
    /// order is read in place where the grid's is the problem's, else through a permuted copy.
    fn derivative(
        &self,
        known: Option<&[f64]>,
        x: &[f64],
        v: &[f64],
        out: &mut [f64],
        ws: &mut WaveWorkspace,
        s: &mut Scratch,
    ) -> CoreResult<()> {
        let curvature = self.v.curvature()?;
        if s.registers.is_empty() {
            s.registers.push(curvature.tile_registers::<f64>(TILE));
        }
        let n = self.grid.points();
        let grid = &mut ws.grid;
        let w = Scratch::sized(&mut s.b, n);
        if self.identity {
            if known.is_none() {
                self.grid.to_grid(x, &mut grid.u, &mut grid.fft);
            }
            self.grid.to_grid(v, w, &mut grid.fft);
        } else {
            let fourier = Scratch::sized(&mut s.a, n);
            if known.is_none() {
                self.gather(x, 0, fourier);
                self.grid.to_grid(fourier, &mut grid.u, &mut grid.fft);
            }
            self.gather(v, 0, fourier);
            self.grid.to_grid(fourier, w, &mut grid.fft);
        }
        curvature.eval_tiles(
            known.unwrap_or(&grid.u),
            Some(&mut grid.g[..]),
            false,
            &mut s.registers[0],
            &mut grid.values,
            TILE,
        );
        for (c, wi) in grid.g.iter_mut().zip(w.iter()) {
            *c *= *wi;
        }
        let scale = 1.0 / n as f64;
        if self.identity {
            self.grid.transpose(&mut grid.g, out, scale, &mut grid.fft);
            return Ok(());
        }
        let fourier = Scratch::sized(&mut s.a, n);
        self.grid
            .transpose(&mut grid.g, fourier, scale, &mut grid.fft);
        for (k, &i) in self.order.iter().enumerate() {
            out[k] = fourier[i];
        }
        Ok(())
    }
}

impl Potential for Wave {
    type Workspace<L: Real> = WaveWorkspace;
    // An AVX2 copy of the kernels (the observing sweep over 10⁴–10⁶ coordinates gains from it:
    // 2¹⁶ points streamed 364 -> 314 µs against the baseline copy), but no AVX-512 one (320 µs,
    // and 2.60 against 2.35 ms on 512²: the FFTs choose their own instructions) and no
    // compile-time shapes: grids are large.
    const AVX512: bool = false;
    const SMALL_SHAPES: bool = false;

    fn dim(&self) -> usize {
        self.grid.points()
    }

    fn workspace<L: Real>(&self) -> WaveWorkspace {
        let n = self.grid.points();
        let fourier = if self.in_place::<L>(&[]).is_some() {
            0
        } else {
            n
        };
        let kept = self.kept.0.lock().ok().and_then(|mut k| k.take());
        let mut ws = match kept {
            Some(ws) if ws.fourier.len() == fourier => ws,
            _ => self.new_workspace(fourier),
        };
        ws.home = Some(Arc::clone(&self.kept.0));
        ws
    }

    fn force<L: Real>(
        &self,
        x: &[L],
        force: &mut [L],
        with_value: bool,
        ws: &mut WaveWorkspace,
    ) -> CoreResult<L> {
        let mut value = L::zero();
        let scale = 1.0 / self.grid.points() as f64;
        let in_place = self.in_place(x).is_some();
        for b in 0..L::LANES {
            value.set_lane(b, self.lane_on_grid(x, b, true, with_value, ws));
            // g = (1/N) Sᵀ(−V'(u)), written into the force in place or through the buffer.
            let grid = &mut ws.grid;
            match L::as_f64s_mut(force).filter(|_| in_place) {
                Some(out) => self.grid.transpose(&mut grid.g, out, scale, &mut grid.fft),
                None => {
                    self.grid
                        .transpose(&mut grid.g, &mut ws.fourier, scale, &mut grid.fft);
                    for (k, &i) in self.order.iter().enumerate() {
                        force[k].set_lane(b, ws.fourier[i]);
                    }
                }
            }
        }
        Ok(value)
    }

    /// The grid values u = S x of the last evaluation: the user's coordinates of a wave problem
    /// (row-major grid values, made by the same [`Spectral::to_grid`] as the coordinate map's
    /// `to_user`). Lanes share one grid buffer, so a bundle of several has none.
    fn evaluated_in_user_coordinates<'w, L: Real>(
        &self,
        ws: &'w WaveWorkspace,
    ) -> Option<&'w [f64]> {
        (L::LANES == 1).then_some(&ws.grid.u[..])
    }

    /// G(q)v = −(1/N) Sᵀ(V''(u) ⊙ S v) with u = S q: two transforms to the grid, the curvature
    /// program of V pointwise, one transform back.
    fn force_derivative(
        &self,
        x: &[f64],
        v: &[f64],
        out: &mut [f64],
        ws: &mut WaveWorkspace,
        s: &mut Scratch,
    ) -> CoreResult<()> {
        self.derivative(None, x, v, out, ws, s)
    }

    /// As [`Wave::force_derivative`], with u = S x the grid values the force at x left (one
    /// transform fewer). `evaluated` must come from a force evaluated at this very x, with no
    /// `value` after it (which leaves the grid values of its own point).
    fn force_derivative_after_force(
        &self,
        evaluated: Option<&[f64]>,
        x: &[f64],
        v: &[f64],
        out: &mut [f64],
        ws: &mut WaveWorkspace,
        s: &mut Scratch,
    ) -> CoreResult<()> {
        let u = evaluated.filter(|u| u.len() == self.grid.points());
        self.derivative(u, x, v, out, ws, s)
    }

    fn value<L: Real>(&self, x: &[L], ws: &mut WaveWorkspace) -> CoreResult<L> {
        let mut value = L::zero();
        for b in 0..L::LANES {
            value.set_lane(b, self.lane_on_grid(x, b, false, true, ws));
        }
        Ok(value)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::potential::{Chain, Op};
    use crate::real::Lanes;

    /// V(u) = u⁴/4 + sin(u).
    fn quartic_and_sine() -> ProgramSpec {
        ProgramSpec {
            n_inputs: 1,
            ops: vec![
                Op::Input(0),
                Op::Powi(0, 4),
                Op::Const(0.25),
                Op::Mul(2, 1),
                Op::Sin(0),
                Op::Add(3, 4),
            ],
            output: 5,
        }
    }

    #[test]
    fn the_force_is_minus_the_gradient() {
        for shape in [vec![16], vec![4, 6], vec![2, 4, 4]] {
            let n: usize = shape.iter().product();
            let order: Vec<usize> = (0..n).rev().collect();
            let w = Wave::new(&shape, &quartic_and_sine(), order).unwrap();
            let mut ws = w.workspace::<f64>();
            let x: Vec<f64> = (0..n).map(|i| 0.3 * ((i as f64) * 0.77).sin()).collect();
            let mut f = vec![0.0; n];
            let u0 = w.force(&x, &mut f, true, &mut ws).unwrap();
            assert_eq!(w.value(&x, &mut ws).unwrap().to_bits(), u0.to_bits());
            for i in 0..n {
                let e = 1e-6;
                let (mut xp, mut xm) = (x.clone(), x.clone());
                xp[i] += e;
                xm[i] -= e;
                let d =
                    (w.value(&xp, &mut ws).unwrap() - w.value(&xm, &mut ws).unwrap()) / (2.0 * e);
                assert!(
                    (f[i] + d).abs() < 1e-8,
                    "{shape:?} coordinate {i}: {} vs {}",
                    f[i],
                    -d
                );
            }
        }
    }

    #[test]
    fn a_constant_field_gives_the_mean_of_v() {
        // u ≡ c is the j = 0 coordinate c; U = V(c).
        let w = Wave::new(&[8], &Chain::monomial(0.25, 4), (0..8).collect()).unwrap();
        let mut x = vec![0.0; 8];
        x[0] = 1.5;
        let u = w.value(&x, &mut w.workspace::<f64>()).unwrap();
        assert!((u - 0.25 * 1.5f64.powi(4)).abs() < 1e-14);
    }

    #[test]
    fn lanes_have_their_own_trajectorys_bits() {
        let w = Wave::new(&[6, 4], &quartic_and_sine(), (0..24).collect()).unwrap();
        let xl: Vec<Lanes<4>> = (0..24)
            .map(|i| Lanes(std::array::from_fn(|b| ((i * (b + 1)) as f64 * 0.31).cos())))
            .collect();
        let mut fl = vec![Lanes::<4>::zero(); 24];
        let ul = w
            .force(&xl, &mut fl, true, &mut w.workspace::<Lanes<4>>())
            .unwrap();
        for b in 0..4 {
            let x: Vec<f64> = xl.iter().map(|v| v.0[b]).collect();
            let mut f = vec![0.0; 24];
            let u = w
                .force(&x, &mut f, true, &mut w.workspace::<f64>())
                .unwrap();
            assert_eq!(u.to_bits(), ul.0[b].to_bits());
            for i in 0..24 {
                assert_eq!(f[i].to_bits(), fl[i].0[b].to_bits());
            }
        }
    }

    #[test]
    fn bad_input_is_refused() {
        let two = ProgramSpec {
            n_inputs: 2,
            ops: vec![Op::Input(0), Op::Input(1), Op::Mul(0, 1)],
            output: 2,
        };
        assert!(Wave::new(&[8], &two, (0..8).collect()).is_err());
        assert!(Wave::new(&[8], &quartic_and_sine(), vec![0; 8]).is_err());
        assert!(Wave::new(&[8], &quartic_and_sine(), (0..7).collect()).is_err());
        assert!(Wave::new(&[7], &quartic_and_sine(), (0..7).collect()).is_err());
    }

    #[test]
    fn the_derivative_after_the_force_has_the_bits_of_the_derivative_alone() {
        // the grid's order and a permuted one, on grids of 1, 2 and 3 axes
        for shape in [vec![16], vec![4, 6], vec![2, 4, 4]] {
            let n: usize = shape.iter().product();
            for order in [(0..n).collect::<Vec<_>>(), (0..n).rev().collect()] {
                let w = Wave::new(&shape, &quartic_and_sine(), order).unwrap();
                let (mut ws, mut ws64) = (w.workspace::<f64>(), w.workspace::<f64>());
                let mut scratch = Scratch::default();
                let x: Vec<f64> = (0..n).map(|i| 0.3 * ((i as f64) * 0.77).sin()).collect();
                let v: Vec<f64> = (0..n).map(|i| ((i as f64) * 1.3).cos()).collect();
                let mut f = vec![0.0; n];
                w.force(&x, &mut f, false, &mut ws).unwrap();
                let made = w.evaluated_in_user_coordinates::<f64>(&ws);
                assert!(made.is_some());
                let (mut after, mut alone) = (vec![0.0; n], vec![0.0; n]);
                w.force_derivative_after_force(made, &x, &v, &mut after, &mut ws64, &mut scratch)
                    .unwrap();
                w.force_derivative(&x, &v, &mut alone, &mut ws64, &mut scratch)
                    .unwrap();
                assert!(after
                    .iter()
                    .zip(&alone)
                    .all(|(a, b)| a.to_bits() == b.to_bits()));
                assert!(alone.iter().any(|&g| g != 0.0), "{shape:?}");
            }
        }
    }
}

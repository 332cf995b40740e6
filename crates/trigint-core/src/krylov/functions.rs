//! The matrix functions of a method's one-step form, f(h√A), as functions of the eigenvalues
//! θ = ω² of A: what the Lanczos method evaluates at the Ritz values.

use crate::error::CoreResult;

/// The functions, in the order of [`FUNCTIONS`]: 1 − cos, χ, ψ, φ, ψ/χ, sin²/(hχ), cos·ψ/χ.
pub const FUNCTION_COUNT: usize = 7;

/// Their names, as the Python layer names the method's coefficients (exported as
/// `_core.KRYLOV_FUNCTIONS`).
pub const FUNCTIONS: [&str; FUNCTION_COUNT] = [
    "one_minus_cos",
    "chi",
    "psi",
    "phi",
    "psi_over_chi",
    "sin2_over_h_chi",
    "c_psi_over_chi",
];

/// Index of a function in [`FUNCTIONS`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Function {
    OneMinusCos = 0,
    Chi = 1,
    Psi = 2,
    Phi = 3,
    PsiOverChi = 4,
    Sin2OverHChi = 5,
    CPsiOverChi = 6,
}

/// Values of every function at some θ: `values[f][i]` = f(θ_i).
pub type Values = [Vec<f64>; FUNCTION_COUNT];

/// A method's functions of θ = ω² at a fixed step size.
pub trait MatrixFunctions: Sync {
    /// Every function at the points θ (≥ 0) into `values` (each row resized to θ's length).
    fn evaluate(&self, theta: &[f64], values: &mut Values) -> CoreResult<()>;

    /// Whether φ ≡ 1 (then the force is taken at q itself, with U(q) from the same pass).
    fn phi_is_identity(&self) -> bool;
}

/// The named filters of the trigonometric methods (2.2) [GNI §XIII.2.2].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Filter {
    /// Gautschi: ψ = sinc²(ξ/2), φ = 1.
    A,
    /// Deuflhard: ψ = sinc ξ, φ = 1.
    B,
    /// García-Archilla, Sanz-Serna, Skeel: ψ = sinc²ξ, φ = sinc ξ.
    C,
    /// Hochbruck–Lubich: ψ = sinc²(ξ/2), φ = sinc ξ (1 + ⅓ sin²(ξ/2)).
    D,
    /// Hairer–Lubich: ψ = sinc²ξ, φ = 1.
    E,
}

impl Filter {
    /// The letters of the filters with closed forms here (exported as `_core.KRYLOV_FILTERS`:
    /// any other named filter takes the Python route, its functions evaluated at the Ritz values).
    pub const LETTERS: &'static [&'static str] = &["A", "B", "C", "D", "E"];

    /// The filter of a letter A–E.
    pub fn from_letter(letter: &str) -> Option<Filter> {
        Some(match letter {
            "A" => Filter::A,
            "B" => Filter::B,
            "C" => Filter::C,
            "D" => Filter::D,
            "E" => Filter::E,
            _ => return None,
        })
    }
}

/// The trigonometric method (2.2) with a named filter, in closed form: χ = sinc ξ, ξ = h√θ,
/// and the one-step form's ψ/χ and sin²ξ/(hχ) = ξ sin ξ / h where χ vanishes.
#[derive(Debug, Clone, Copy)]
pub struct Trigonometric {
    pub h: f64,
    pub filter: Filter,
}

impl Trigonometric {
    /// The seven numbers at ξ = hω.
    fn at(&self, xi: f64) -> [f64; FUNCTION_COUNT] {
        if xi == 0.0 {
            return [0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 1.0];
        }
        let (s, half) = (xi.sin(), (0.5 * xi).sin());
        let one_minus_cos = 2.0 * half * half;
        let chi = s / xi;
        let sinc_half = half / (0.5 * xi);
        let (psi, phi) = match self.filter {
            Filter::A => (sinc_half * sinc_half, 1.0),
            Filter::B => (chi, 1.0),
            Filter::C => (chi * chi, chi),
            Filter::D => (sinc_half * sinc_half, chi * (1.0 + half * half / 3.0)),
            Filter::E => (chi * chi, 1.0),
        };
        let (psi_over_chi, sin2_over_h_chi) = if chi != 0.0 {
            (psi / chi, s * s / (self.h * chi))
        } else {
            // the limits at ξ = kπ (ψ/sinc in closed form; A and D: 2 tan(ξ/2)/ξ)
            let ratio = match self.filter {
                Filter::A | Filter::D => 2.0 * (0.5 * xi).tan() / xi,
                Filter::B => 1.0,
                Filter::C | Filter::E => chi,
            };
            (ratio, xi * s / self.h)
        };
        let c_psi_over_chi = (1.0 - one_minus_cos) * psi_over_chi;
        [
            one_minus_cos,
            chi,
            psi,
            phi,
            psi_over_chi,
            sin2_over_h_chi,
            c_psi_over_chi,
        ]
    }
}

impl MatrixFunctions for Trigonometric {
    fn evaluate(&self, theta: &[f64], values: &mut Values) -> CoreResult<()> {
        for row in values.iter_mut() {
            row.clear();
        }
        for &t in theta {
            let v = self.at(self.h * t.max(0.0).sqrt());
            for (row, x) in values.iter_mut().zip(v) {
                row.push(x);
            }
        }
        Ok(())
    }

    fn phi_is_identity(&self) -> bool {
        matches!(self.filter, Filter::A | Filter::B | Filter::E)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closed_forms_at_a_few_points() {
        let b = Trigonometric {
            h: 0.1,
            filter: Filter::B,
        };
        let mut v: Values = Default::default();
        let xi: f64 = 1.3;
        b.evaluate(&[(xi / 0.1) * (xi / 0.1), 0.0], &mut v).unwrap();
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-14 * b.abs().max(1.0);
        assert!(close(v[Function::OneMinusCos as usize][0], 1.0 - xi.cos()));
        assert!(close(v[Function::Chi as usize][0], xi.sin() / xi));
        assert!(close(v[Function::PsiOverChi as usize][0], 1.0));
        assert!(close(
            v[Function::Sin2OverHChi as usize][0],
            xi * xi.sin() / 0.1
        ));
        assert_eq!(v[Function::Psi as usize][1], 1.0);
        let d = Trigonometric {
            h: 0.1,
            filter: Filter::D,
        };
        d.evaluate(&[(xi / 0.1) * (xi / 0.1)], &mut v).unwrap();
        let sinc = xi.sin() / xi;
        let half = (xi / 2.0).sin();
        assert!(close(
            v[Function::Phi as usize][0],
            sinc * (1.0 + half * half / 3.0)
        ));
        assert!(close(
            v[Function::Psi as usize][0],
            (half / (xi / 2.0)).powi(2)
        ));
        assert!(!d.phi_is_identity() && b.phi_is_identity());
    }
}

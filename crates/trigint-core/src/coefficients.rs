//! Per-coordinate method coefficients.
//!
//! Every method of the paper is the recursion (trigo-mod),
//!
//!   q_{n+1} − 2 cos(hω̃) q_n + q_{n−1} = h² ψ g(φ q_n),   2h χ p_n = q_{n+1} − q_{n−1},
//!
//! with per-coordinate numbers c = cos(hω̃), s = sin(hω̃), χ, ψ, φ (ω̃ = ω and χ = sinc(hω)
//! for the trigonometric methods (trigo)). The Python layer evaluates the filter functions
//! and hands these arrays over; here they are checked and turned into the products the
//! kernels use, so that a method is data and the loop is one.
//!
//! The kernels take 1 − c = 2 sin²(½hω̃) rather than c: it is known to full relative
//! precision, so the summed form of the recursion (see `stepper`) has no systematic phase
//! error from the rounding of cos(hω̃), which for small hω̃ is amplified by 1/sin(hω̃).

use crate::error::{CoreError, CoreResult};

/// The method numbers per coordinate, as evaluated at hω̃_i.
#[derive(Debug, Clone)]
pub struct MethodCoefficients {
    pub h: f64,
    /// 1 − cos(hω̃_i) = 2 sin²(½hω̃_i), to full relative precision.
    pub one_minus_cos: Vec<f64>,
    /// sin(hω̃_i), used by the one-step form only.
    pub sin: Vec<f64>,
    /// χ(hω̃_i); sinc(hω_i) for trigonometric methods. Must not vanish.
    pub chi: Vec<f64>,
    /// ψ(hω̃_i)
    pub psi: Vec<f64>,
    /// φ(hω̃_i)
    pub phi: Vec<f64>,
}

impl MethodCoefficients {
    /// Number of coordinates.
    pub fn dim(&self) -> usize {
        self.one_minus_cos.len()
    }

    /// Checks lengths, finiteness and χ ≠ 0.
    pub fn validate(&self) -> CoreResult<()> {
        if !(self.h.is_finite() && self.h > 0.0) {
            return Err(CoreError::invalid(
                "h",
                format!("must be finite and > 0, got {}", self.h),
            ));
        }
        let n = self.dim();
        if n == 0 {
            return Err(CoreError::invalid(
                "coefficients",
                "need at least one coordinate",
            ));
        }
        for (name, v) in [
            ("sin", &self.sin),
            ("chi", &self.chi),
            ("psi", &self.psi),
            ("phi", &self.phi),
        ] {
            if v.len() != n {
                return Err(CoreError::invalid(
                    "coefficients",
                    format!("`{name}` has {} entries, `one_minus_cos` has {n}", v.len()),
                ));
            }
        }
        for (name, v) in [
            ("one_minus_cos", &self.one_minus_cos),
            ("sin", &self.sin),
            ("chi", &self.chi),
            ("psi", &self.psi),
            ("phi", &self.phi),
        ] {
            if let Some(i) = v.iter().position(|x| !x.is_finite()) {
                return Err(CoreError::invalid(
                    "coefficients",
                    format!("`{name}` is not finite at coordinate {i}: {}", v[i]),
                ));
            }
        }
        if let Some(i) = self.chi.iter().position(|&x| x == 0.0) {
            return Err(CoreError::invalid(
                "coefficients",
                format!("chi vanishes at coordinate {i}: the momentum p_n is undefined there"),
            ));
        }
        Ok(())
    }

    /// The kernel-ready products; call after [`validate`](Self::validate).
    pub fn kernel(&self) -> KernelCoefficients {
        let h = self.h;
        let n = self.dim();
        let mut k = KernelCoefficients {
            n,
            phi_is_identity: self.phi.iter().all(|&x| x == 1.0),
            one_minus_cos: self.one_minus_cos.clone(),
            two_one_minus_cos: Vec::with_capacity(n),
            h2_psi: Vec::with_capacity(n),
            half_h2_psi: Vec::with_capacity(n),
            phi: self.phi.clone(),
            inv_2h_chi: Vec::with_capacity(n),
            h_chi: Vec::with_capacity(n),
            p_from_q: Vec::with_capacity(n),
            half_h_psi0: Vec::with_capacity(n),
            half_h_psi1: Vec::with_capacity(n),
        };
        for i in 0..n {
            let (omc, s, chi, psi) = (self.one_minus_cos[i], self.sin[i], self.chi[i], self.psi[i]);
            let c = 1.0 - omc;
            k.two_one_minus_cos.push(2.0 * omc);
            k.h2_psi.push(h * h * psi);
            k.half_h2_psi.push(0.5 * h * h * psi);
            k.inv_2h_chi.push(1.0 / (2.0 * h * chi));
            k.h_chi.push(h * chi);
            // One-step form: p_{n+1} = −s²/(hχ) q_n + c p_n + ½h (cψ/χ g_n + ψ/χ g_{n+1});
            // for χ = sinc(hω) this is −ω sin(hω) q_n + … [GNI XIII (2.7)–(2.9)].
            k.p_from_q.push(-(s * s) / (h * chi));
            k.half_h_psi0.push(0.5 * h * c * psi / chi);
            k.half_h_psi1.push(0.5 * h * psi / chi);
        }
        k
    }
}

/// Products of the method numbers that the stepping kernels read.
#[derive(Debug, Clone)]
pub struct KernelCoefficients {
    pub n: usize,
    /// φ ≡ 1: the force is evaluated at q_n itself and shares its pass with U(q_n).
    pub phi_is_identity: bool,
    /// 1 − c and 2(1 − c)
    pub one_minus_cos: Vec<f64>,
    pub two_one_minus_cos: Vec<f64>,
    pub h2_psi: Vec<f64>,
    pub half_h2_psi: Vec<f64>,
    pub phi: Vec<f64>,
    pub inv_2h_chi: Vec<f64>,
    pub h_chi: Vec<f64>,
    pub p_from_q: Vec<f64>,
    pub half_h_psi0: Vec<f64>,
    pub half_h_psi1: Vec<f64>,
}

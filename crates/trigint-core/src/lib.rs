//! trigint-core: the numerical core of trigint.
//!
//! Long-time integration of q'' + Ω²q = −∇U(q) by trigonometric and modified trigonometric
//! integrators (Cohen, Gauckler, Hairer, Lubich, BIT 2015). Methods arrive as per-coordinate
//! coefficient arrays ([`MethodCoefficients`]); one generic kernel steps every method.

pub mod batch;
pub mod coefficients;
pub mod driver;
pub mod energy;
pub mod error;
#[doc(hidden)]
pub mod fixtures;
pub mod potential;
pub mod stepper;

pub use batch::{integrate_batch, BatchSpec, TrajectoryMethod, TrajectoryOutput};
pub use coefficients::{KernelCoefficients, MethodCoefficients};
pub use driver::{integrate, Form, RunOutput, RunSpec, Status};
pub use energy::{EnergyLayout, Recorder, Samples};
pub use error::{CoreError, CoreResult};
pub use potential::{Fpu, Polynomial, Potential};

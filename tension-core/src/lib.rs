//! # tension-core
//!
//! Kinematics and tension distribution for cable-driven parallel robots
//! (CDPRs), following the project's `docs/conventions.md`: frames, the XYZ Euler
//! convention, the wrench matrix `W` and the method names.
//!
//! * `#![no_std]`, no `alloc`, no `unsafe`; every matrix has a size fixed at
//!   compile time (`N` degrees of freedom, `M` cables) and every loop has a
//!   bound known before it starts.
//! * Generic over the scalar ([`Real`]: `f32` on the board, `f64` on the host).
//! * Feature `std` (off by default; the host crates of this workspace turn
//!   it on): the processor's square root, sine and cosine through `std`
//!   instead of libm's software ones (and libm's x86 square root, inline
//!   assembly that stalls inside AVX code). A host build should enable it,
//!   with `-C target-cpu=native` or without (`cargo bench --bench
//!   native_flags` measures both).
//! * Every public function checks its inputs and returns a typed [`Error`]
//!   instead of panicking; nalgebra's iterative decompositions (SVD,
//!   eigen-solvers), which loop forever on NaN, are not used at all.
//!
//! The methods ([`Method`], one module each under [`methods`], all with the
//! same signature): `barycenter` (Lamaury & Gouttefarde 2013),
//! `barycenter-brute` (Mikelsons et al. 2008), `analytic-centre` (Di Paola
//! et al. 2024), `closed-form` and `improved-closed-form` (Pott et al. 2009,
//! Pott 2013), `puncture` and `improved-puncture` (Müller, Reichert &
//! Bruckmann 2014), `min-2-norm`, `min-1-norm` and `optimally-safe`
//! (Borgstrom et al. 2009).
//!
//! [`solve`] runs one method on `W`, `f` and the limits; [`TensionSolver`]
//! does the same with the warm-start state a control loop carries
//! ([`PreviousCycle`]); [`trajectory::time_law`] is the point-to-point time
//! law the tools and tests move along. [`Robot::forward_kinematics`]
//! ([`forward_kinematics`]) finds the pose from measured cable lengths.
//! The numerical tolerances the methods share are in [`tolerance`].

#![no_std]
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod active_set;
mod error;
pub mod forward_kinematics;
pub mod kinematics;
mod limits;
pub mod linalg;
pub mod methods;
pub mod polygon;
mod polygon_optimum;
mod scalar;
mod solution;
mod solver;
pub mod tension_polygon;
pub mod tolerance;
pub mod trajectory;

pub use error::Error;
pub use forward_kinematics::{ForwardError, ForwardFailure, ForwardSettings, ForwardSolution};
pub use kinematics::{CableState, Motion, MotorTorque, Platform, Pose, Robot, RobotKind, Winch};
pub use limits::TensionLimits;
pub use methods::analytic_centre::{
    AnalyticCentre, AnalyticCentreSettings, BarrierWeights, ConvexConstraint,
};
pub use methods::{solve, Method, PreviousCycle, Problem};
pub use polygon::{ActivePair, Bound};
pub use scalar::{all_finite, max, min, Real};
pub use solution::{robustness, Diagnostics, Solution, WarmStart};
pub use solver::TensionSolver;

/// Re-exported so that callers name the same matrix types.
pub use nalgebra;

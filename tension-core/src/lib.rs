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
//! * Every public function checks its inputs and returns a typed [`Error`]
//!   instead of panicking; nalgebra's iterative decompositions (SVD,
//!   eigen-solvers), which loop forever on NaN, are not used at all.
//!
//! The methods ([`Method`]):
//! * [`barycenter`]: Lamaury & Gouttefarde 2013, walking the edges of the
//!   feasible polygon (`M = N + 2`), warm-started from the previous cycle;
//! * [`barycenter_brute`]: Mikelsons et al. 2008, every pairwise intersection;
//! * [`analytic_centre`]: Di Paola et al. 2024, Newton's method, any redundancy;
//! * [`closed_form`] and [`improved_closed_form`]: Pott et al. 2009, Pott 2013;
//! * [`puncture`] and [`improved_puncture`]: Müller, Reichert & Bruckmann 2014;
//! * [`min_2_norm`] and [`min_1_norm`]: the smallest tensions in the 2- and
//!   1-norm, exactly on the polygon for `r = 2`, by active sets otherwise;
//! * [`optimally_safe`]: Borgstrom et al. 2009, the largest distance to a limit.
//!
//! [`TensionSolver`] bundles them behind one call with the warm-start state;
//! [`trajectory::time_law`] is the point-to-point time law the tools and tests
//! move along.

#![no_std]
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod active_set;
pub mod analytic_centre;
pub mod barycenter;
pub mod closed_form;
mod error;
pub mod kinematics;
mod limits;
pub mod linalg;
pub mod norms;
pub mod optimally_safe;
pub mod polygon;
pub mod puncture;
mod scalar;
mod solution;
mod solver;
pub mod trajectory;

pub use analytic_centre::{
    analytic_centre, AnalyticCentre, AnalyticCentreSettings, BarrierWeights, ConvexConstraint,
};
pub use barycenter::{barycenter, barycenter_brute, ActivePair, Bound};
pub use closed_form::{closed_form, improved_closed_form};
pub use error::Error;
pub use kinematics::{CableState, Motion, MotorTorque, Platform, Pose, Robot, RobotKind, Winch};
pub use limits::TensionLimits;
pub use norms::{min_1_norm, min_2_norm};
pub use optimally_safe::optimally_safe;
pub use puncture::{improved_puncture, puncture};
pub use scalar::Real;
pub use solution::{robustness, Diagnostics, Solution, WarmStart};
pub use solver::{Method, TensionSolver};

/// Re-exported so that callers name the same matrix types.
pub use nalgebra;

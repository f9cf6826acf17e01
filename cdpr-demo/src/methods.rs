//! Which tension distribution methods the board offers over the link, and
//! why: the one statement of it, which the product applies
//! (`ControlLoop::offer_only(offered())`) and the demo's replay checks
//! against what it measures.
//!
//! A method is offered when its stated worst solve plus the stated rest of
//! the control step fits [`BUDGET`] (20 000 instructions per 1 ms step, the
//! figure every step of the demo is held to), or when it is the loop's own
//! method ([`LOOP_METHOD`], barycenter), whose every step the demo
//! measures whole and holds to the budget directly (the sum of two worst
//! cases that do not happen in the same cycle says less). The stated
//! figures are the worst cases measured on the board (QEMU, `-icount
//! shift=3`) on the robots `cargo xtask test` runs (suspended-8 and
//! ipanema1), the larger of two measurements, rounded up by 1 to 5 %:
//! the demo's 4600 poses (`cargo xtask run`: rest at the centre, jumps
//! between poses, the loop with its excursion out of the workspace, each
//! robot on its own derived trajectory) and the full stress set
//! (`cargo xtask stress --poses 100000`, `crate::stress`: uniform over the
//! setpoint range, the workspace border, angle limits, extra wrenches,
//! lost warm starts). The barycenter's, the solver in the loop, measured
//! 12 828 on suspended-8's demo (its cold start where the loop begins) and
//! 12 999 over suspended-8's stress set (an infeasible pose); the
//! iterative methods' worst are the stress set's border poses (session 28:
//! analytic-centre 366 895, min-2-norm 55 027, min-1-norm 101 149 on
//! suspended-8, optimally-safe 226 072 on suspended-8's uniform poses;
//! over the demo alone they had been stated at 115 000, 18 600, 18 600 and
//! 215 000). `cargo xtask test` fails this table ([`exceeded`]) when a
//! measured worst, the demo's or the short stress run's, exceeds its
//! stated one; the full stress run fails it too.

use tension_core::Method;

use crate::BUDGET;

/// A method's stated worst solve on the board, instructions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MethodCost {
    /// The method.
    pub method: Method,
    /// Its worst solve, instructions (measured, rounded up).
    pub worst: u32,
}

/// The control step without the solver, worst case, on a board with CAN
/// drives: the setpoint's checks, reading the encoders, kinematics, the
/// pose estimator, the feedback, torques, state machine and the drives'
/// CiA 402 layer. The demo measures it in every cycle as the step less its
/// solve (`Report::rest_worst`), and `cargo xtask test` holds both demos to
/// this figure.
///
/// Measured (session 35):
/// - the demo: 4 754, on both suspended-8 and ipanema1;
/// - with the drive layer inside (`CDPR_DEMO_CAN_LAYER=1`): 9 007 and
///   8 997, with one setpoint frame a cycle.
///
/// The product takes at most two frames a cycle (about 350-490 more), so
/// the figure is 9 007 + 490, rounded up to 10 000. Until session 35 it was
/// 7 000: the phases' maxima of issue 13, without the drive layer.
pub const STEP_REST: u32 = 10_000;

/// The control loop's method (the firmware's default): offered whatever
/// the table says, its steps being measured whole.
pub const LOOP_METHOD: Method = Method::Barycenter;

/// Every method's stated worst solve, in `Method::ALL` order.
pub const COSTS: [MethodCost; 10] = [
    MethodCost { method: Method::Barycenter, worst: 13_500 },
    MethodCost { method: Method::BarycenterBrute, worst: 40_000 },
    MethodCost { method: Method::AnalyticCentre, worst: 385_000 },
    MethodCost { method: Method::ClosedForm, worst: 3_800 },
    MethodCost { method: Method::ImprovedClosedForm, worst: 23_500 },
    MethodCost { method: Method::Puncture, worst: 5_200 },
    MethodCost { method: Method::ImprovedPuncture, worst: 25_000 },
    MethodCost { method: Method::Min2Norm, worst: 58_000 },
    MethodCost { method: Method::Min1Norm, worst: 106_000 },
    MethodCost { method: Method::OptimallySafe, worst: 238_000 },
];

/// The stated worst solve of `method`.
pub const fn stated_worst(method: Method) -> u32 {
    let mut i = 0;
    while i < COSTS.len() {
        if COSTS[i].method.wire_id() == method.wire_id() {
            return COSTS[i].worst;
        }
        i += 1;
    }
    u32::MAX
}

/// Whether the board offers `method`: the [`LOOP_METHOD`], or its stated
/// worst solve plus [`STEP_REST`] within [`BUDGET`].
pub const fn is_offered(method: Method) -> bool {
    method.wire_id() == LOOP_METHOD.wire_id() || stated_worst(method).saturating_add(STEP_REST) <= BUDGET
}

/// The methods the board offers (barycenter, closed-form, puncture).
pub const fn offered() -> cdpr_control::MethodSet {
    let mut set = cdpr_control::MethodSet::EMPTY;
    let mut i = 0;
    while i < COSTS.len() {
        if is_offered(COSTS[i].method) {
            set = set.with(COSTS[i].method);
        }
        i += 1;
    }
    set
}

/// Whether a measured worst solve of `method` exceeds its stated one (the
/// table must then be remeasured, and may offer less).
pub const fn exceeded(method: Method, measured: u32) -> bool {
    measured > stated_worst(method)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_covers_every_method_in_order_and_offers_the_cheap_ones() {
        for (cost, method) in COSTS.iter().zip(Method::ALL) {
            assert_eq!(cost.method, method);
        }
        let expected = [Method::Barycenter, Method::ClosedForm, Method::Puncture];
        for method in Method::ALL {
            assert_eq!(offered().contains(method), expected.contains(&method), "{}", method.name());
            assert_eq!(offered().contains(method), is_offered(method));
        }
        assert!(!offered().contains(Method::OptimallySafe));
        assert!(exceeded(Method::Barycenter, 13_501) && !exceeded(Method::Barycenter, 13_500));
    }
}

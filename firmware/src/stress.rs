//! The stress run (the `stress` program, `cargo xtask stress`; issue 17,
//! goal 2): every method over the stress set of [`cdpr_demo::stress`]
//! (as many poses as the program is built for: uniform over the setpoint range, the workspace border
//! by bisection, Euler angles at their limits, extra wrenches, walks whose
//! warm start is lost by jumps), on the board's f32 code, each solve timed
//! with interrupts off, warm starts carried from pose to pose as in the
//! loop. It prints, per method, the worst solve, the pose that gives it
//! and its kind, and the outcomes; then the barycenter's analytical bound
//! ([`Bound`]), and exits with [`cdpr_demo::exit::PASS`] when the
//! barycenter's worst is within its bound and, in the short run (at most
//! [`cdpr_demo::stress::SHORT_RUN`] poses, the test command's), every
//! method's worst within its regression ceiling
//! ([`cdpr_demo::stress::CEILINGS`], measured over those poses: a longer
//! run meets harder poses, and prints the ceilings without judging by
//! them), and in every run every method's worst within the stated worst
//! the board's offer comes from (`cdpr_demo::methods::COSTS`: the larger
//! of the demo trajectory's and the full stress set's worst on the shipped
//! robots), [`cdpr_demo::exit::FAIL`] otherwise.

use cdpr_control::controller::{Controller, Wrench};
use cdpr_control::link::SetpointRange;
use cdpr_control::{Setpoint, TickCounter, CABLES};
use cdpr_demo::stress::{bisect, ceiling, Draw, Kind, StressSet};
use cdpr_demo::{exit, methods};
use tension_core::linalg::WrenchFactorization;
use tension_core::polygon::VertexList;
use tension_core::tension_polygon::TensionPolygon;
use tension_core::Method;

use crate::clock::{ticks_to_units as units, Tim2Counter};
use crate::{bsp, robot, Board};

/// The worst solve of one method.
#[derive(Clone, Copy)]
struct Worst {
    cost: u32,
    pose_index: u32,
    kind: Kind,
    pose: [f32; 6],
    extra: [f32; 6],
    outcome: &'static str,
}

/// Outcome counts of one method.
#[derive(Clone, Copy, Default)]
struct Counts {
    ok: u32,
    infeasible: u32,
    other: u32,
}

/// The barycenter's analytical worst case from constants measured over
/// the set, each phase's largest: `factorisation + 2 (polygon set-up +
/// first vertex search + 2M x per-vertex walk) + rest`. The walk visits at
/// most `2M` vertices (the polygon is convex and cut by the `2M`
/// half-planes `t_min <= t <= t_max`: Mikelsons et al. 2008, Sect. 3); the
/// first vertex's search (Eq. 8, the cold start, also what certifies an
/// infeasible pose) is timed on its own; the per-vertex cost is the walk
/// from that vertex divided by the vertices it visits; a warm-started
/// attempt that fails without a proof is tried again cold
/// (`tension_core::methods::solve`), hence twice; the rest is what a
/// single attempt costs beyond those phases (the solution, the robustness,
/// the warm start's check). A walk after a held warm start first tries
/// the previous polygon's lines (`walk_into`'s hints) and stops after one
/// wrong hint: that test (the crossing and at most two passes over the
/// cables, each no dearer than a full step's) is counted as two more
/// vertices ([`HINT_TEST_STEPS`]).
#[derive(Clone, Copy, Default)]
struct Bound {
    factorisation: u32,
    polygon: u32,
    search: u32,
    per_vertex: u32,
    rest: u32,
    most_vertices: u32,
}

/// A wrong hint's test in the walk, in full steps (see [`Bound`]).
const HINT_TEST_STEPS: u32 = 2;

impl Bound {
    /// The walk's steps in an attempt: at most `2 M` vertices, plus one
    /// wrong hint's test.
    const STEPS: u32 = 2 * CABLES as u32 + HINT_TEST_STEPS;

    fn value(&self) -> u32 {
        let attempt = self.polygon + self.search + Self::STEPS * self.per_vertex;
        self.factorisation + 2 * attempt + self.rest
    }
}

fn controller(method: Method) -> Controller {
    match robot::robot().and_then(|robot| Controller::new(robot, method)) {
        Ok(c) => c,
        Err(e) => panic!("robot description rejected: {}", e.status()),
    }
}

/// Runs the first `poses` poses of the stress set and exits with the verdict.
pub fn run(board: &mut Board, poses: u32) -> ! {
    let clock = &board.clock;
    let robot = board.control.controller().robot();
    let range = SetpointRange::for_robot(robot);
    let limits = *robot.limits();
    let tension_range = limits.max()[0] - limits.min()[0];
    let centre = robot::CENTRE;
    let set = StressSet::new(range.position_min, range.position_max, range.angle_max, centre, tension_range);
    defmt::println!(
        "stress run: {=str}, {=u32} poses (uniform, border, angle limits, extra wrench up to {=f32} N / {=f32} N m, sequences), {=usize} methods",
        robot::NAME,
        poses,
        0.5 * tension_range,
        0.1 * tension_range,
        Method::ALL.len(),
    );
    let Some(solvers) =
        cortex_m::singleton!(: [Controller; 10] = core::array::from_fn(|i| controller(Method::ALL[i])))
    else {
        panic!("stress controllers taken twice");
    };
    let mut feasibility = controller(Method::Barycenter);
    let none =
        Worst { cost: 0, pose_index: 0, kind: Kind::Uniform, pose: [0.0; 6], extra: [0.0; 6], outcome: "" };
    let mut worst = [none; 10];
    let mut kind_worst = [[0u32; 6]; 10];
    let mut counts = [Counts::default(); 10];
    let mut bound = Bound::default();
    let mut generator = set;
    // Whether the barycenter has a warm start (after its first success).
    let mut had_start = false;
    for k in 0..poses {
        let (pose, extra, kind) = match generator.draw() {
            Draw::Pose { pose, extra, kind } => (pose, extra, kind),
            Draw::Ray { inside, outside } => {
                let border = bisect(inside, outside, |p| solves(&mut feasibility, p));
                (border, [0.0; 6], Kind::Border)
            }
        };
        let setpoint = at_rest(k, &pose);
        let extra_wrench = Wrench::from(extra);
        let kind_at = Kind::ALL.iter().position(|&x| x == kind).unwrap_or(0);
        let mut barycenter_cost = 0;
        for (m, solver) in solvers.iter_mut().enumerate() {
            let Ok((w, f)) = solver.wrench(&setpoint, &extra_wrench) else {
                counts[m].other += 1;
                continue;
            };
            let (ticks, result) = cortex_m::interrupt::free(|_| {
                let start = clock.ticks();
                let result = solver.solve(&w, &f);
                (clock.since(start), result)
            });
            let cost = units(ticks);
            let outcome = match &result {
                Ok(_) => {
                    counts[m].ok += 1;
                    "ok"
                }
                Err(tension_core::Error::Infeasible) => {
                    counts[m].infeasible += 1;
                    "infeasible"
                }
                Err(_) => {
                    counts[m].other += 1;
                    "other error"
                }
            };
            if cost > worst[m].cost {
                worst[m] = Worst { cost, pose_index: k, kind, pose, extra, outcome };
            }
            kind_worst[m][kind_at] = kind_worst[m][kind_at].max(cost);
            if Method::ALL[m] == Method::Barycenter {
                // One attempt unless a warm start was given and the answer
                // is not from it (tried again cold: `NotGiven`, or an
                // error that proves nothing).
                let retried = match &result {
                    Ok(sol) => had_start && sol.diagnostics.warm_start == tension_core::WarmStart::NotGiven,
                    Err(e) => had_start && !e.is_certain(),
                };
                barycenter_cost = if retried { 0 } else { cost };
                had_start |= result.is_ok();
            }
        }
        // The barycenter's phases on the same pose, cold (no warm start: the
        // first vertex searched), for the bound's constants.
        if let Ok((w, f)) = solvers[0].wrench(&setpoint, &extra_wrench) {
            phases(clock, &w, &f, &limits, barycenter_cost, &mut bound);
        }
        if k % 10_000 == 9_999 {
            defmt::println!("stress run: {=u32} of {=u32} poses", k + 1, poses);
        }
    }
    let mut pass = true;
    // The ceilings are the short run's (its poses' worst plus a margin).
    let judged = poses <= cdpr_demo::stress::SHORT_RUN;
    for (m, method) in Method::ALL.iter().enumerate() {
        let w = &worst[m];
        let stated = methods::stated_worst(*method);
        let limit = ceiling(*method);
        pass &= (!judged || w.cost <= limit) && w.cost <= stated;
        let c = counts[m];
        defmt::println!(
            "stress {=str}: worst {=u32} {=str} at pose {=u32} ({=str}, {=str}) [x y z rx ry rz] = {} extra {}; ceiling {=u32}: {=str}; the offer table's worst {=u32}: {=str}; {=u32} ok, {=u32} infeasible, {=u32} other; worst by kind (uniform, border, angle limits, extra wrench, sequence, jumps) {}",
            method.name(),
            w.cost,
            bsp::UNIT,
            w.pose_index,
            w.kind.name(),
            w.outcome,
            w.pose,
            w.extra,
            limit,
            match (w.cost <= limit, judged) {
                (true, _) => "within",
                (false, true) => "OVER",
                (false, false) => "above (the short run's ceiling: not judged beyond it)",
            },
            stated,
            if w.cost <= stated { "within" } else { "OVER" },
            c.ok,
            c.infeasible,
            c.other,
            kind_worst[m],
        );
    }
    let b = bound.value();
    let barycenter = worst[0].cost;
    pass &= barycenter <= b;
    defmt::println!(
        "stress bound, barycenter: factorisation {=u32} + 2 x (polygon {=u32} + first-vertex search {=u32} + {=u32} steps (2 M vertices, one wrong hint's test) x {=u32} a vertex) + rest {=u32} = {=u32} {=str}; most vertices seen {=u32}; measured worst {=u32}: {=str}",
        bound.factorisation,
        bound.polygon,
        bound.search,
        Bound::STEPS,
        bound.per_vertex,
        bound.rest,
        b,
        bsp::UNIT,
        bound.most_vertices,
        barycenter,
        if barycenter <= b { "within" } else { "OVER" },
    );
    let code = if pass { exit::PASS } else { exit::FAIL };
    defmt::println!("stress run: {=str} (exit code {=i32})", if pass { "PASS" } else { "FAIL" }, code);
    crate::exit(code)
}

/// The setpoint `seq` at `pose` at rest (the stress set's velocities and
/// accelerations are zero).
fn at_rest(seq: u32, pose: &[f32; 6]) -> Setpoint {
    Setpoint { seq, pose: (*pose).into(), velocity: Default::default(), acceleration: Default::default() }
}

/// Whether the barycenter solves `pose` (the border's bisection).
fn solves(c: &mut Controller, pose: &[f32; 6]) -> bool {
    let setpoint = at_rest(0, pose);
    c.wrench(&setpoint, &Wrench::zeros()).and_then(|(w, f)| c.solve(&w, &f)).is_ok()
}

/// Times the barycenter's phases on one pose (filled in place, as
/// `TensionSolver::solve` does: factorisation, polygon, the cold first
/// vertex, the walk from it) and folds them into `bound`; `solve_cost` is
/// the same pose's whole warm-started solve when it made one attempt (0
/// when it was tried again cold).
fn phases(
    clock: &Tim2Counter,
    w: &cdpr_control::controller::WrenchMatrix,
    f: &Wrench,
    limits: &tension_core::TensionLimits<f32, CABLES>,
    solve_cost: u32,
    bound: &mut Bound,
) {
    use tension_core::polygon::{ActivePair, Bound as Side};
    let side = |h: u8| if h % 2 == 1 { Side::Max } else { Side::Min };
    cortex_m::interrupt::free(|_| {
        let t0 = clock.ticks();
        let mut fact = WrenchFactorization::zeroed();
        let Ok(()) = fact.factor(w, &[true; CABLES], 2) else { return };
        let t1 = clock.ticks();
        let mut poly = TensionPolygon::zeroed();
        let Ok(()) = poly.set(&fact, f, limits) else { return };
        let t2 = clock.ticks();
        // The cold search in index order. The walk starts it from a lost
        // warm start's cutting cable (`first_vertex_from`); its worst case,
        // every line clipped and then the pairs of the lines left open, is
        // the same in any order, and the infeasible poses reach it.
        let first = poly.polygon.first_vertex();
        let t3 = clock.ticks();
        let (fa, po, se) =
            (units(t1.wrapping_sub(t0)), units(t2.wrapping_sub(t1)), units(t3.wrapping_sub(t2)));
        bound.factorisation = bound.factorisation.max(fa);
        bound.polygon = bound.polygon.max(po);
        bound.search = bound.search.max(se);
        let mut walked = 0;
        if let Some(v) = first {
            let (h1, h2) = v.lines;
            let pair = ActivePair { first: (h1 / 2, side(h1)), second: (h2 / 2, side(h2)) };
            let mut vertices = VertexList::new();
            let t4 = clock.ticks();
            let found = poly.polygon.walk_into(Some(pair), &mut vertices);
            walked = units(clock.ticks().wrapping_sub(t4));
            if let Ok(summary) = found {
                let n = summary.vertices.max(1) as u32;
                bound.per_vertex = bound.per_vertex.max(walked.div_ceil(n));
                bound.most_vertices = bound.most_vertices.max(n);
            }
        }
        // A retried solve (`solve_cost` 0) says nothing about the rest.
        bound.rest = bound.rest.max(solve_cost.saturating_sub(fa + po + se + walked));
    });
}

//! Forward kinematics: the pose from measured cable lengths (issue 13,
//! part 1), with the conventions' frames and cables (`docs/conventions.md`,
//! "Forward kinematics").
//!
//! # The problem
//! Find the pose `x` (`[x, y, z, rx, ry, rz]`, `[x, y, theta]` or `[x, y]`)
//! whose cable lengths match the measured ones `L`: the residual is
//! `r_i(x) = |a_i - p - R b_i| - L_i` (m), minimised in the least-squares
//! sense (`M >= N`, so with `M > N` the lengths over-determine the pose and
//! the smallest residual tells whether any pose has them).
//!
//! # The Jacobian and its sign
//! `J = dr/dx = dl/dx` (`M x N`). By virtual work, a small displacement `dp`
//! and a small rotation `omega` (base frame) change the cable lengths by
//! `dl = -W^T [dp; omega]`, `W` the wrench matrix: lengthening a cable moves
//! the platform away from its anchor, against `u_i`. With XYZ Euler angles,
//! `omega = E(rx, ry) [rx'; ry'; rz']` with `E = [j1 j2 j3]`,
//! `j1 = e_x`, `j2 = Rx(rx) e_y`, `j3 = Rx(rx) Ry(ry) e_z`, the same map as
//! [`crate::Motion::from_pose_derivatives`], so
//! `J = -W^T diag(I_3, E)` for `spatial6`; `J = -W^T` for `planar3`
//! (`omega = theta' e_z`) and `planar2`. (Tested against finite
//! differences in `tests/forward_kinematics.rs`.)
//!
//! # The method
//! Damped Gauss-Newton (Levenberg-Marquardt, Marquardt's scaling
//! `mu diag(J^T J)`) on `sum r_i^2`, the `N x N` normal equations solved by
//! a bounded `L D L^T` ([`crate::linalg::Ldl`]). One *iteration* evaluates
//! the cables once at a trial point (one rotation matrix from one `sin_cos`
//! per angle, reused for `E`, and `M` square roots). The Gauss-Newton step
//! is taken first; a trial that raises the cost is rejected and the damping
//! raised (`1e-3`, times 10 per rejection, divided by 10 per accepted damped
//! step). After an accepted step the Jacobian is not rebuilt at once: the
//! next step is first computed with the previous factorisation (a chord
//! step, `N^2 + 2 M N` multiply-adds); if its length change is already below
//! the tolerance the run has converged without another Jacobian. So when the
//! pose moved a few millimetres since the last cycle the warm path costs two
//! cable evaluations, one Jacobian with its `6 x 6` factorisation, and two
//! triangular solves.
//!
//! A run *converges* when the undamped step's length change `|J dx|_inf`
//! is at most [`ForwardSettings::tolerance`] (or `sqrt(eps)` times the
//! worst residual: the least-squares minimum to the type's precision); the
//! answer is the point where that step was computed, so the residuals
//! reported are exact there. A run that meets the iteration cap ends
//! *inconsistent* instead of unconverged when its last step found the
//! lengths beyond reach: the linear model's best worst residual beyond
//! twice [`ForwardSettings::consistency`], the step within an eighth of it
//! (lengths no pose has, where Gauss-Newton converges only linearly).
//!
//! # Warm and cold starts
//! * Warm: one run from the previous cycle's pose.
//! * Cold (no warm pose, or the warm run did not converge, or converged
//!   with a worst residual above [`ForwardSettings::consistency`], or ended
//!   on the mirror side of a flat anchor plane): runs from a fixed list of
//!   starts. The first pose inside the *region* whose worst residual is
//!   within a tenth of the consistency threshold ends the search; otherwise
//!   every start runs and the consistent pose with the smallest worst
//!   residual is returned (a local minimum a little below the threshold,
//!   seen on small platforms, loses to the true pose). The region is the anchors' bounding box (x, y for planar
//!   robots); along an axis where the anchors span at most a tenth of the
//!   box's largest side (a suspended robot's anchors all near one height)
//!   the box is *flat* and reaches from the anchors to the base origin
//!   (when the anchors' plane passes within that tenth of the origin, it
//!   reaches as far as the box is wide to the side gravity points, the
//!   negative side without gravity along it). The
//!   platform hangs on that side: a pose whose attachments' centroid lies on
//!   the other side of a flat anchor plane (the mirror pose of coplanar
//!   anchors, with the same lengths) is never returned, warm or cold. A
//!   consistent pose outside the box (by more than 5 % of the robot's size)
//!   but on the right side is returned only when no start gives one inside,
//!   and never one farther from the box than the robot's size (warm or
//!   cold: the lengths of a robot 1e30 m away are consistent to rounding).
//! * Starts, in order: (1) trilateration: with `R = I` the points
//!   `a_i - b_i` are `L_i` from `p`, linear least squares for `p` in the
//!   axes that are not flat, a flat axis placed on the platform's side at
//!   the remaining mean distance; (2) `spatial6` only: that position tilted
//!   by `(+-0.3, +-0.3)` rad about x and y (four starts); then the
//!   attachments' centroid at the region's centre at zero orientation; then
//!   `spatial6`: `rz = pi/2, -pi/2, pi`; `planar3`: `theta = +-pi/4, +-pi/2,
//!   +-3pi/4, pi` (the angle has local minima); then the centres of the
//!   region's eight octants (four quadrants in the plane) at zero
//!   orientation.
//! * Measured region (`tests/forward_kinematics.rs`, the cold-start grid):
//!   for `spatial6`, every pose of a 5 x 5 x 5 grid of the attachments'
//!   centroid over the region shrunk by 10 % of each side (suspended-8:
//!   x in [-1.6, 1.6], y in [-1.2, 1.2], z in [0.35, 3.15]), times `rx, ry`
//!   in `{-0.3, 0, 0.3}` and `rz` in `{-0.5, 0, 0.5}` (3 375 poses per
//!   robot; suspended-8, IPAnema 1, CoGiRo and spatial6-10 in f64,
//!   suspended-8 in f32) is found; for `planar3-5` a 9 x 9 grid times 9
//!   angles over `[-pi, pi)` (729, f64 and f32), for `planar-point-4` a
//!   9 x 9 grid (81). Without the tilted starts 18 of suspended-8's poses
//!   0.2 m below the anchors with both tilts at 0.3 rad end in local minima.
//!
//! # Cost (worst case, fixed caps)
//! A run makes at most `max_iterations` iterations and `max_iterations + 1`
//! cable evaluations; each iteration builds at most one Jacobian (`M N`
//! entries, `N(N+1)M/2` multiply-adds for `J^T J`) and makes at most two
//! `L D L^T` factorisations (`N^3/6`) and three triangular solves. The warm
//! run is one run; the cold start is at most `S` more (`S` = 17 for
//! `spatial6`, 13 for `planar3`, 6 for `planar2`). So at most
//! `(S + 1)(max_iterations + 1)` cable evaluations: 558 for `spatial6` with
//! the default 30 iterations (the measured grids need at most 218
//! iterations, CoGiRo; the warm path of a 1 kHz trajectory 1 in f32 and 3 in
//! f64, where the tolerance is at rounding level).
//!
//! No allocation, no panic, no `unsafe`; every loop has a fixed bound.
//! Euler angles are singular at `|ry| = pi/2` (gimbal lock): there `E`, so
//! `J`, loses rank and the answer is [`ForwardError::IllConditioned`].

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

use crate::{
    kinematics::{Pose, Robot, RobotKind},
    linalg::Ldl,
    scalar::{all_finite, greater, max},
    tolerance, Real,
};

/// Why no pose was returned.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ForwardError {
    /// A length, the guess or the geometry is NaN or infinite, or a length
    /// is negative.
    NonFinite,
    /// `M < N`, or `N` does not match the robot's kind.
    UnsupportedShape,
    /// The iteration cap was hit (the warm run and every cold start).
    NoConvergence,
    /// The Jacobian is singular or ill-conditioned at the answer: its
    /// [condition](ForwardSolution::condition) is beyond
    /// [`ForwardSettings::condition_max`].
    IllConditioned,
    /// No pose of the robot has these lengths (a stretched, slack or broken
    /// cable, a wrong homing): a run converged with its worst residual
    /// beyond [`ForwardSettings::consistency`] or met the cap with the
    /// lengths beyond reach (module documentation), and no start gave a
    /// consistent pose within the robot's size of its region (the lengths
    /// of a robot 1e30 m away are consistent: the closest pose reported is
    /// then that far pose, its residual small).
    InconsistentLengths,
}

impl ForwardError {
    /// The one-word status of the conventions' tables: `nonfinite`,
    /// `unsupported-shape`, `no-convergence`, `ill-conditioned`,
    /// `inconsistent-lengths`.
    pub fn status(self) -> &'static str {
        match self {
            ForwardError::NonFinite => "nonfinite",
            ForwardError::UnsupportedShape => "unsupported-shape",
            ForwardError::NoConvergence => "no-convergence",
            ForwardError::IllConditioned => "ill-conditioned",
            ForwardError::InconsistentLengths => "inconsistent-lengths",
        }
    }
}

impl core::fmt::Display for ForwardError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.status())
    }
}

/// The stopping rules and acceptance thresholds of the forward kinematics.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForwardSettings<T: Real> {
    /// Iterations (cable evaluations at a trial point) per run: the warm
    /// run, and each cold-start run.
    pub max_iterations: u32,
    /// m: a run has converged when the undamped step's length change
    /// `|J dx|_inf` is at most this, or at most `sqrt(eps)` times the
    /// worst residual (a least-squares minimum to the type's precision:
    /// lengths that no pose has end there, or at the iteration cap beyond
    /// reach of consistency: the module documentation).
    pub tolerance: T,
    /// m: a converged pose whose worst `|residual|` is above this is
    /// inconsistent ([`ForwardError::InconsistentLengths`]; on the warm run it
    /// triggers the cold start first).
    pub consistency: T,
    /// A condition ([`ForwardSolution::condition`]) above this is
    /// [`ForwardError::IllConditioned`].
    pub condition_max: T,
}

impl<T: Real> ForwardSettings<T> {
    /// Defaults for a robot of size `s` (the largest side of the anchors'
    /// box or attachment coordinate, m; 4 m for suspended-8) whose
    /// coordinates reach `c` (the largest anchor or attachment coordinate,
    /// at least `s`; `c = s` for a base frame at the robot, as in every
    /// file of `robots/`):
    /// * `max_iterations = 30` (a run from the grids' starts that converges
    ///   needs at most about 20; the warm path of a 1 kHz trajectory 1 to 3);
    /// * `tolerance = 32 eps c`: the lengths' own rounding is a few `eps c`,
    ///   and the step's length change is the residual projected on `J`'s
    ///   range, so this stays reachable (f64, c = 4: 2.8e-14 m; f32: 1.5e-5 m);
    /// * `consistency = max(2.5e-4 s, 1e3 eps c)`: 1 mm for s = 4 m, far
    ///   above an encoder count (2 um on suspended-8) and the rounding, far
    ///   below a slack or slipped cable, wherever the base frame lies;
    /// * `condition_max = 0.05 / sqrt(eps)`: 3.4e6 in f64, 145 in f32, where
    ///   `condition * eps` is the relative rounding of the pose that the
    ///   normal equations leave (`cond^2 eps` for `J^T J`), kept under
    ///   about 2.5e-3 (f32) of the robot's size.
    pub fn for_robot<const N: usize, const M: usize>(robot: &Robot<T, N, M>) -> Self {
        let (s, magnitude) = robot_sizes(robot);
        let eps = T::eps();
        Self {
            max_iterations: 30,
            tolerance: T::lit(32.0) * eps * magnitude,
            consistency: (T::lit(2.5e-4) * s).max(T::lit(1.0e3) * eps * magnitude),
            condition_max: T::lit(0.05) / eps.sqrt_native(),
        }
    }
}

/// A pose that has the measured lengths, and how well.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForwardSolution<T: Real, const N: usize, const M: usize> {
    /// The pose, conventions' order; angles in `(-pi, pi]`, and `|ry| <=
    /// pi/2` for `spatial6` (the other Euler triple of the same rotation is
    /// mapped to this one).
    pub pose: Pose<T, N>,
    /// Iterations, over the warm run and every cold-start run.
    pub iterations: u32,
    /// `|a_i - p - R b_i| - L_i` at the answer, m.
    pub residuals: SVector<T, M>,
    /// Root mean square of the residuals, m.
    pub rms: T,
    /// Largest `|residual|`, m.
    pub worst: T,
    /// `1 / min_j sin(phi_j)`, `phi_j` the angle between column `j` of the
    /// Jacobian and the span of the columns before it: the inverse smallest
    /// diagonal entry of the Cholesky factor of `J` with unit columns, a
    /// lower bound on that matrix's condition number `cond_2` (exact for
    /// orthogonal columns; infinite for a singular `J`). Computed at the last
    /// point the Jacobian was built, within one step (below the tolerance in
    /// length) of the answer.
    pub condition: T,
    /// `true` when the warm start was not given or did not hold.
    pub cold_started: bool,
}

/// Why no pose was returned, with the closest pose found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForwardFailure<T: Real, const N: usize, const M: usize> {
    /// The reason.
    pub error: ForwardError,
    /// The pose with the smallest worst residual among the runs that ended
    /// (converged or at the cap), if any run could start at all; for
    /// [`ForwardError::IllConditioned`] and
    /// [`ForwardError::InconsistentLengths`] the converged pose.
    pub closest: Option<ForwardSolution<T, N, M>>,
}

/// A robot's `(size, magnitude)`, each at least 1e-30 (so that scaled
/// tolerances of a robot at the origin are not zero):
/// * its size: the largest side of the anchors' box or attachment
///   coordinate. Where the base frame lies does not change it. A slack or
///   slipped cable, and how far a pose may lie from the robot, are
///   measured against it (with the base frame 50 m beside suspended-8 the
///   largest coordinate, used before, had made a 13 mm error consistent,
///   against 1 mm);
/// * the magnitude of its coordinates: the largest anchor or attachment
///   coordinate, or its size. What the rounding of lengths and poses
///   scales with.
fn robot_sizes<T: Real, const N: usize, const M: usize>(robot: &Robot<T, N, M>) -> (T, T) {
    let (mut size, mut coordinates) = (T::lit(1.0e-30), T::lit(1.0e-30));
    let (mut lo, mut hi) = (robot.anchors()[0], robot.anchors()[0]);
    // Plain comparisons: `f32::max` is a libm call on the board.
    for i in 0..M {
        let (a, b) = (robot.anchors()[i], robot.attachments()[i].amax());
        size = max(size, b);
        coordinates = max(max(coordinates, a.amax()), b);
        lo = lo.inf(&a);
        hi = hi.sup(&a);
    }
    let size = max(size, (hi - lo).amax());
    (size, max(coordinates, size))
}

/// The region the cold start searches, and the flat anchor planes.
#[derive(Debug, Clone, Copy)]
struct Region<T: Real> {
    lo: Vector3<T>,
    hi: Vector3<T>,
    /// Per axis: 0 (not flat), or the side (`+1`, `-1`) the platform hangs
    /// on from `plane[k]`.
    side: [T; 3],
    plane: Vector3<T>,
    /// Mean attachment `b` (platform frame; zero for planar2).
    b_mean: Vector3<T>,
    /// The robot's size ([`robot_sizes`]).
    size: T,
    /// The magnitude of its coordinates ([`robot_sizes`]).
    magnitude: T,
}

impl<T: Real> Region<T> {
    fn of<const N: usize, const M: usize>(robot: &Robot<T, N, M>) -> Self {
        let axes = if robot.kind() == RobotKind::Spatial6 { 3 } else { 2 };
        let (mut lo, mut hi) = (robot.anchors()[0], robot.anchors()[0]);
        let mut b_mean = Vector3::zeros();
        for i in 0..M {
            lo = lo.inf(&robot.anchors()[i]);
            hi = hi.sup(&robot.anchors()[i]);
            b_mean += robot.attachments()[i];
        }
        b_mean /= T::lit(M as f64);
        if robot.kind() == RobotKind::Planar2 {
            b_mean = Vector3::zeros();
        }
        if axes == 2 {
            lo.z = T::zero();
            hi.z = T::zero();
            b_mean.z = T::zero();
        }
        let widest = (hi - lo).amax();
        let gravity = robot.platform().gravity;
        let mut side = [T::zero(); 3];
        let mut plane = Vector3::zeros();
        let tenth = T::lit(0.1) * widest;
        for k in 0..axes {
            if hi[k] - lo[k] > tenth {
                continue;
            }
            let mid = (hi[k] + lo[k]) * T::lit(0.5);
            let up = mid < -tenth || (mid <= tenth && gravity[k] > T::zero());
            let s = if up { T::one() } else { -T::one() };
            side[k] = s;
            if s < T::zero() {
                plane[k] = lo[k];
                lo[k] = if mid > tenth { T::zero() } else { lo[k] - widest };
            } else {
                plane[k] = hi[k];
                hi[k] = if mid < -tenth { T::zero() } else { hi[k] + widest };
            }
        }
        let (size, magnitude) = robot_sizes(robot);
        Self { lo, hi, side, plane, b_mean, size, magnitude }
    }

    /// The attachments' centroid (`p + R b_mean`) is not beyond a flat
    /// anchor plane.
    fn right_side(&self, centroid: &Vector3<T>) -> bool {
        (0..3).all(|k| self.side[k] == T::zero() || (centroid[k] - self.plane[k]) * self.side[k] > T::zero())
    }

    /// Inside the box grown by `grow` times the robot's size.
    fn inside(&self, centroid: &Vector3<T>, grow: T) -> bool {
        let m = grow * self.size;
        (0..3).all(|k| centroid[k] >= self.lo[k] - m && centroid[k] <= self.hi[k] + m)
    }
}

/// The cables at one pose: what the residual and the Jacobian need.
#[derive(Debug, Clone, Copy)]
struct Point<T: Real, const N: usize, const M: usize> {
    x: Pose<T, N>,
    r: SVector<T, M>,
    cost: T,
    u: [Vector3<T>; M],
    rb: [Vector3<T>; M],
    /// `sin rx, cos rx, sin ry, cos ry` (spatial6), for `E`.
    trig: [T; 4],
}

/// The state of one run: the point, its (possibly earlier) Jacobian and
/// the factorisation of `J^T J`.
struct Linear<T: Real, const N: usize, const M: usize> {
    j: SMatrix<T, M, N>,
    a: SMatrix<T, N, N>,
    factor: Option<Ldl<T, N>>,
    condition: T,
}

/// How a run ended.
#[derive(Debug, Clone, Copy)]
struct RunEnd<T: Real, const N: usize, const M: usize> {
    point: Point<T, N, M>,
    converged: bool,
    condition: T,
}

fn worst_of<T: Real, const M: usize>(r: &SVector<T, M>) -> T {
    let mut w = T::zero();
    for i in 0..M {
        let a = r[i].abs();
        if a > w {
            w = a;
        }
    }
    w
}

/// `value <= limit`, false for NaN.
fn consistent<T: Real>(value: T, limit: T) -> bool {
    value <= limit
}

/// `x` wrapped into `(-pi, pi]`.
fn wrap<T: Real>(x: T) -> T {
    let pi = T::pi();
    if x > -pi && x <= pi {
        return x;
    }
    let tau = T::two_pi();
    let y = x - tau * ((x + pi) / tau).floor();
    // y in [-pi, pi) up to rounding
    if y <= -pi {
        y + tau
    } else if y > pi {
        y - tau
    } else {
        y
    }
}

impl<T: Real, const N: usize, const M: usize> Robot<T, N, M> {
    /// The pose whose cable lengths are `lengths` (m, cable order), by damped
    /// Gauss-Newton on `r_i = |a_i - p - R b_i| - L_i`, warm-started from
    /// `warm` (the previous cycle's pose; `None`: cold start). See the
    /// module documentation ([`crate::forward_kinematics`]) for the
    /// Jacobian `J = dr/dx = -W^T diag(I, E)`, the starts, the measured
    /// region and the worst-case cost.
    pub fn forward_kinematics(
        &self,
        lengths: &SVector<T, M>,
        warm: Option<&Pose<T, N>>,
        settings: &ForwardSettings<T>,
    ) -> Result<ForwardSolution<T, N, M>, ForwardError> {
        self.forward_kinematics_attempt(lengths, warm, settings).map_err(|f| f.error)
    }

    /// The Jacobian the forward kinematics uses, `J = dl/dx` (`M x N`, m per
    /// m or per rad): `-W^T diag(I_3, E)` for `spatial6`, `-W^T` for the
    /// planar kinds (module documentation); `None` for a non-finite pose or a
    /// cable of (numerically) zero length.
    pub fn length_jacobian(&self, pose: &Pose<T, N>) -> Option<SMatrix<T, M, N>> {
        if N != self.kind().dof() {
            return None;
        }
        let floor = tolerance::degenerate_length(robot_sizes(self).1);
        let pt = self.evaluate(pose, &SVector::zeros(), floor)?;
        Some(self.linearise(&pt).j)
    }

    /// [`Self::forward_kinematics`], with the closest pose found when it
    /// fails (for diagnostics: how inconsistent the lengths are).
    pub fn forward_kinematics_attempt(
        &self,
        lengths: &SVector<T, M>,
        warm: Option<&Pose<T, N>>,
        settings: &ForwardSettings<T>,
    ) -> Result<ForwardSolution<T, N, M>, ForwardFailure<T, N, M>> {
        let fail = |error| ForwardFailure { error, closest: None };
        if N != self.kind().dof() || M < N {
            return Err(fail(ForwardError::UnsupportedShape));
        }
        // Every length finite and not negative (NaN fails the comparison).
        if !all_finite(lengths.iter().copied()) || !lengths.iter().all(|&l| l >= T::zero()) {
            return Err(fail(ForwardError::NonFinite));
        }
        if let Some(w) = warm {
            if !all_finite(w.iter().copied()) {
                return Err(fail(ForwardError::NonFinite));
            }
        }
        let s = settings;
        if !all_finite([s.tolerance, s.consistency, s.condition_max]) {
            return Err(fail(ForwardError::NonFinite));
        }
        let region = Region::of(self);
        let floor = tolerance::degenerate_length(region.magnitude);
        let mut iterations = 0u32;
        // The closest converged run and the closest of any run, for the
        // failure report (a converged, inconsistent run outranks the cap).
        let mut closest: [Option<RunEnd<T, N, M>>; 2] = [None, None];
        let mut note = |end: &RunEnd<T, N, M>| {
            for (slot, take) in closest.iter_mut().zip([end.converged, true]) {
                let better = match slot {
                    None => true,
                    Some(c) => worst_of(&end.point.r) < worst_of(&c.point.r),
                };
                if take && better {
                    *slot = Some(*end);
                }
            }
        };
        if let Some(w) = warm {
            if let Some((end, used)) = self.run(w, lengths, s, floor) {
                iterations += used;
                match self.classify(&end, &region, s) {
                    Verdict::Accept | Verdict::Outside => {
                        return self.finish(&end, iterations, false, s);
                    }
                    Verdict::Reject => note(&end),
                }
            }
        }
        // The consistent candidates with the smallest worst residual, inside
        // the box and outside it; one within a tenth of the consistency
        // threshold inside the box ends the search at once.
        let mut found: [Option<RunEnd<T, N, M>>; 2] = [None, None];
        let clear = s.consistency * T::lit(0.1);
        for k in 0..COLD_STARTS {
            let Some(start) = self.cold_start(&region, lengths, k) else { continue };
            let Some((end, used)) = self.run(&start, lengths, s, floor) else { continue };
            iterations += used;
            let slot = match self.classify(&end, &region, s) {
                Verdict::Accept if worst_of(&end.point.r) <= clear => {
                    return self.finish(&end, iterations, true, s);
                }
                Verdict::Accept => 0,
                Verdict::Outside => 1,
                Verdict::Reject => {
                    note(&end);
                    continue;
                }
            };
            let better = match &found[slot] {
                None => true,
                Some(c) => worst_of(&end.point.r) < worst_of(&c.point.r),
            };
            if better {
                found[slot] = Some(end);
            }
        }
        if let Some(end) = found[0].or(found[1]) {
            return self.finish(&end, iterations, true, s);
        }
        Err(match closest {
            [Some(end), _] => ForwardFailure {
                error: ForwardError::InconsistentLengths,
                closest: Some(self.solution(&end, iterations, true)),
            },
            [None, Some(end)] => ForwardFailure {
                error: ForwardError::NoConvergence,
                closest: Some(self.solution(&end, iterations, true)),
            },
            [None, None] => fail(ForwardError::NoConvergence),
        })
    }

    fn classify(&self, end: &RunEnd<T, N, M>, region: &Region<T>, s: &ForwardSettings<T>) -> Verdict {
        // Not converged, inconsistent, the mirror pose (consistent lengths,
        // the wrong side of a flat anchor plane), or farther from the box
        // than the robot's size (lengths of 1e30 m are consistent to
        // rounding with a pose 1e30 m away, which is not this robot's).
        let c = self.centroid(&end.point);
        if !end.converged
            || !consistent(worst_of(&end.point.r), s.consistency)
            || !region.right_side(&c)
            || !region.inside(&c, T::one())
        {
            return Verdict::Reject;
        }
        if region.inside(&c, T::lit(0.05)) {
            Verdict::Accept
        } else {
            Verdict::Outside
        }
    }

    /// `p + R b_mean` from the point's `R b_i`.
    fn centroid(&self, pt: &Point<T, N, M>) -> Vector3<T> {
        let mut c = Vector3::zeros();
        for rb in &pt.rb {
            c += rb;
        }
        c /= T::lit(M as f64);
        let z = if self.kind() == RobotKind::Spatial6 { pt.x[2] } else { T::zero() };
        c + Vector3::new(pt.x[0], pt.x[1], z)
    }

    fn finish(
        &self,
        end: &RunEnd<T, N, M>,
        iterations: u32,
        cold: bool,
        s: &ForwardSettings<T>,
    ) -> Result<ForwardSolution<T, N, M>, ForwardFailure<T, N, M>> {
        let sol = self.solution(end, iterations, cold);
        if !consistent(sol.condition, s.condition_max) {
            return Err(ForwardFailure { error: ForwardError::IllConditioned, closest: Some(sol) });
        }
        Ok(sol)
    }

    fn solution(&self, end: &RunEnd<T, N, M>, iterations: u32, cold: bool) -> ForwardSolution<T, N, M> {
        let r = end.point.r;
        let mut pose = end.point.x;
        match self.kind() {
            RobotKind::Spatial6 => {
                let (mut a, mut b, mut c) = (wrap(pose[3]), wrap(pose[4]), wrap(pose[5]));
                let half = T::frac_pi_2();
                if b > half || b < -half {
                    // Rx(a + pi) Ry(pi - b) Rz(c + pi) is the same rotation.
                    a = wrap(a + T::pi());
                    b = wrap(T::pi() - b);
                    c = wrap(c + T::pi());
                }
                pose[3] = a;
                pose[4] = b;
                pose[5] = c;
            }
            RobotKind::Planar3 => pose[2] = wrap(pose[2]),
            RobotKind::Planar2 => {}
        }
        ForwardSolution {
            pose,
            iterations,
            residuals: r,
            rms: (end.point.cost / T::lit(M as f64)).sqrt_native(),
            worst: worst_of(&r),
            condition: end.condition,
            cold_started: cold,
        }
    }

    /// Start `k` of the cold start (see the module documentation), `None`
    /// past the last.
    fn cold_start(&self, region: &Region<T>, lengths: &SVector<T, M>, k: usize) -> Option<Pose<T, N>> {
        if k == 0 {
            return self.trilateration(region, lengths);
        }
        let tilted = if self.kind() == RobotKind::Spatial6 { TILTS } else { 0 };
        if k <= tilted {
            // The trilateration's position, tilted by +-0.3 rad about x and y.
            let mut x = self.trilateration(region, lengths)?;
            let t = T::lit(0.3);
            x[3] = if k & 1 == 0 { t } else { -t };
            x[4] = if k & 2 == 0 { t } else { -t };
            return Some(x);
        }
        let k = k - 1 - tilted;
        let half = T::lit(0.5);
        let centre = (region.lo + region.hi) * half;
        let quarter = (region.hi - region.lo) * T::lit(0.25);
        let pi = T::pi();
        // (position offset in quarters of the box, angle index, angle)
        let (offset, angle): ([i8; 3], T) = match self.kind() {
            RobotKind::Spatial6 => match k {
                0 => ([0; 3], T::zero()),
                1 => ([0; 3], pi * half),
                2 => ([0; 3], -pi * half),
                3 => ([0; 3], pi),
                4..=11 => (octant(k - 4), T::zero()),
                _ => return None,
            },
            RobotKind::Planar3 => match k {
                0 => ([0; 3], T::zero()),
                1..=7 => {
                    let angles = [0.25, -0.25, 0.5, -0.5, 0.75, -0.75, 1.0];
                    ([0; 3], pi * T::lit(angles[k - 1]))
                }
                8..=11 => (quadrant(k - 8), T::zero()),
                _ => return None,
            },
            RobotKind::Planar2 => match k {
                0 => ([0; 3], T::zero()),
                1..=4 => (quadrant(k - 1), T::zero()),
                _ => return None,
            },
        };
        let target = centre
            + Vector3::new(
                quarter.x * T::lit(offset[0] as f64),
                quarter.y * T::lit(offset[1] as f64),
                quarter.z * T::lit(offset[2] as f64),
            );
        let mut x = Pose::<T, N>::zeros();
        match self.kind() {
            RobotKind::Spatial6 => {
                // Rz(angle) b_mean sits at the target.
                let (s, c) = angle.sin_cos_native();
                let b = region.b_mean;
                let rb = Vector3::new(c * b.x - s * b.y, s * b.x + c * b.y, b.z);
                let p = target - rb;
                x[0] = p.x;
                x[1] = p.y;
                x[2] = p.z;
                x[5] = angle;
            }
            RobotKind::Planar3 => {
                let (s, c) = angle.sin_cos_native();
                let b = region.b_mean;
                x[0] = target.x - (c * b.x - s * b.y);
                x[1] = target.y - (s * b.x + c * b.y);
                x[2] = angle;
            }
            RobotKind::Planar2 => {
                x[0] = target.x;
                x[1] = target.y;
            }
        }
        Some(x)
    }

    /// The first cold start: the position by trilateration at zero
    /// orientation. With `R = I` the points `a_i - b_i` are at distance
    /// `L_i` from `p`; subtracting the mean of `|a_i - b_i - p|^2 = L_i^2`
    /// gives linear least squares for `p` in the axes that are not flat;
    /// along a flat axis `p` is then placed on the platform's side at the
    /// mean remaining distance. `None` when that system is singular.
    fn trilateration(&self, region: &Region<T>, lengths: &SVector<T, M>) -> Option<Pose<T, N>> {
        let axes = if self.kind() == RobotKind::Spatial6 { 3 } else { 2 };
        let used = |k: usize| k < axes && region.side[k] == T::zero();
        let point = |i: usize| {
            let mut q = self.anchors()[i];
            if self.kind() != RobotKind::Planar2 {
                q -= self.attachments()[i];
            }
            if axes == 2 {
                q.z = T::zero();
            }
            q
        };
        let inv_m = T::one() / T::lit(M as f64);
        let mut mean = Vector3::zeros();
        let mut mean_l2 = T::zero();
        let mut mean_q2 = T::zero();
        for i in 0..M {
            let q = point(i);
            mean += q * inv_m;
            mean_l2 += lengths[i] * lengths[i] * inv_m;
            mean_q2 += q.norm_squared() * inv_m;
        }
        // -2 (q_i - mean) . p = L_i^2 - mean_l2 - |q_i|^2 + mean_q2, over the used axes.
        let mut c = Matrix3::<T>::zeros();
        let mut rhs = Vector3::<T>::zeros();
        for i in 0..M {
            let mut d = (point(i) - mean) * T::lit(-2.0);
            for k in 0..3 {
                if !used(k) {
                    d[k] = T::zero();
                }
            }
            let q = point(i);
            let e = lengths[i] * lengths[i] - mean_l2 - q.norm_squared() + mean_q2;
            c += d * d.transpose();
            rhs += d * e;
        }
        for k in 0..3 {
            if !used(k) {
                c[(k, k)] = T::one();
                rhs[k] = T::zero();
            }
        }
        let (f, _) = Ldl::factor(&c).ok()?;
        let mut p = f.solve(&rhs);
        let mut flat_sq = T::zero();
        let mut count = T::zero();
        for k in 0..axes {
            if region.side[k] != T::zero() {
                p[k] = mean[k];
            }
        }
        if (0..axes).any(|k| region.side[k] != T::zero()) {
            // The squared distance left for the flat axes, averaged.
            for i in 0..M {
                let d = point(i) - p;
                flat_sq += lengths[i] * lengths[i] - d.norm_squared();
                count += T::one();
            }
            let off = (flat_sq / count).max(T::zero()).sqrt_native();
            // All flat axes share it (one flat axis in practice).
            for k in 0..axes {
                if region.side[k] != T::zero() {
                    p[k] = mean[k] + region.side[k] * off;
                }
            }
        }
        let mut x = Pose::<T, N>::zeros();
        x[0] = p.x;
        x[1] = p.y;
        if self.kind() == RobotKind::Spatial6 {
            x[2] = p.z;
        }
        if all_finite(x.iter().copied()) {
            Some(x)
        } else {
            None
        }
    }

    /// The cables at `x`: residuals, directions and `R b_i`; `None` when a
    /// number is not finite or a cable is shorter than `floor`.
    fn evaluate(&self, x: &Pose<T, N>, lengths: &SVector<T, M>, floor: T) -> Option<Point<T, N, M>> {
        let z = T::zero();
        let mut trig = [z, T::one(), z, T::one()];
        let (p, rot) = match self.kind() {
            RobotKind::Spatial6 => {
                let (sa, ca) = x[3].sin_cos_native();
                let (sb, cb) = x[4].sin_cos_native();
                let (sc, cc) = x[5].sin_cos_native();
                trig = [sa, ca, sb, cb];
                // Rx(a) Ry(b) Rz(c), multiplied out.
                let rot = Matrix3::new(
                    cb * cc,
                    -cb * sc,
                    sb,
                    sa * sb * cc + ca * sc,
                    ca * cc - sa * sb * sc,
                    -sa * cb,
                    sa * sc - ca * sb * cc,
                    ca * sb * sc + sa * cc,
                    ca * cb,
                );
                (Vector3::new(x[0], x[1], x[2]), rot)
            }
            RobotKind::Planar3 => {
                let (s, c) = x[2].sin_cos_native();
                (Vector3::new(x[0], x[1], z), Matrix3::new(c, -s, z, s, c, z, z, z, T::one()))
            }
            RobotKind::Planar2 => (Vector3::new(x[0], x[1], z), Matrix3::identity()),
        };
        let mut pt = Point {
            x: *x,
            r: SVector::zeros(),
            cost: z,
            u: [Vector3::zeros(); M],
            rb: [Vector3::zeros(); M],
            trig,
        };
        for i in 0..M {
            let b = self.attachments()[i];
            let a = self.anchors()[i];
            let (rb, a) = match self.kind() {
                RobotKind::Spatial6 => (rot * b, a),
                RobotKind::Planar3 => (
                    Vector3::new(
                        rot[(0, 0)] * b.x + rot[(0, 1)] * b.y,
                        rot[(1, 0)] * b.x + rot[(1, 1)] * b.y,
                        z,
                    ),
                    Vector3::new(a.x, a.y, z),
                ),
                RobotKind::Planar2 => (Vector3::zeros(), Vector3::new(a.x, a.y, z)),
            };
            let l = a - p - rb;
            let length = l.norm_squared().sqrt_native();
            if !greater(length, floor) {
                return None;
            }
            let ri = length - lengths[i];
            pt.r[i] = ri;
            pt.cost += ri * ri;
            pt.u[i] = l / length;
            pt.rb[i] = rb;
        }
        if pt.cost.is_finite() && all_finite(x.iter().copied()) {
            Some(pt)
        } else {
            None
        }
    }

    /// `J = dr/dx` at a point (`-W^T diag(I, E)`, module documentation), and
    /// `J^T J`, its factorisation and condition.
    fn linearise(&self, pt: &Point<T, N, M>) -> Linear<T, N, M> {
        let mut j = SMatrix::<T, M, N>::zeros();
        let [sa, ca, sb, cb] = pt.trig;
        for i in 0..M {
            let u = pt.u[i];
            let rb = pt.rb[i];
            let mut row = [T::zero(); 6];
            match self.kind() {
                RobotKind::Spatial6 => {
                    let m = rb.cross(&u);
                    row = [
                        -u.x,
                        -u.y,
                        -u.z,
                        -m.x,
                        -(ca * m.y + sa * m.z),
                        -(sb * m.x - sa * cb * m.y + ca * cb * m.z),
                    ];
                }
                RobotKind::Planar3 => {
                    row[0] = -u.x;
                    row[1] = -u.y;
                    row[2] = -(rb.x * u.y - rb.y * u.x);
                }
                RobotKind::Planar2 => {
                    row[0] = -u.x;
                    row[1] = -u.y;
                }
            }
            for k in 0..N {
                j[(i, k)] = row[k];
            }
        }
        let mut a = SMatrix::<T, N, N>::zeros();
        for c in 0..N {
            for r in c..N {
                let mut s = T::zero();
                for i in 0..M {
                    s += j[(i, r)] * j[(i, c)];
                }
                a[(r, c)] = s;
                a[(c, r)] = s;
            }
        }
        let (factor, condition) = match Ldl::factor(&a) {
            Ok((f, ratio)) => (Some(f), ratio.sqrt_native()),
            Err(_) => (None, T::max_value().unwrap_or_else(T::one)),
        };
        Linear { j, a, factor, condition }
    }

    /// One damped Gauss-Newton run from `start` with at most
    /// `settings.max_iterations` iterations; `None` when the start itself
    /// cannot be evaluated. Returns the end and the iterations used.
    fn run(
        &self,
        start: &Pose<T, N>,
        lengths: &SVector<T, M>,
        s: &ForwardSettings<T>,
        floor: T,
    ) -> Option<(RunEnd<T, N, M>, u32)> {
        let mut cur = self.evaluate(start, lengths, floor)?;
        let mut lin = self.linearise(&cur);
        let mut stale = false;
        let mut mu = T::zero();
        let mu_min = T::lit(1.0e-3);
        let mu_max = T::lit(1.0e12);
        let slack = T::one() + T::lit(64.0) * T::eps();
        let mut used = 0u32;
        let mut converged = false;
        // Whether the last Gauss-Newton step found the lengths beyond reach
        // (`gauss_newton`).
        let mut beyond_reach = false;
        let mut condition = lin.condition;
        while used < s.max_iterations {
            // The undamped (Gauss-Newton) step; with a stale Jacobian, the
            // chord step, and a refresh when that is not yet small.
            let mut gn = gauss_newton(&lin, &cur.r, s, used + 1 >= s.max_iterations);
            if stale && !matches!(gn, Step::Converged) {
                lin = self.linearise(&cur);
                stale = false;
                gn = gauss_newton(&lin, &cur.r, s, used + 1 >= s.max_iterations);
            }
            condition = lin.condition;
            beyond_reach = matches!(gn, Step::Full(_, true));
            let dx = match gn {
                Step::Converged => {
                    converged = true;
                    break;
                }
                Step::Full(dx, _) if mu == T::zero() => dx,
                _ => {
                    if mu == T::zero() {
                        mu = mu_min;
                    }
                    match damped(&lin, &cur.r, mu) {
                        // A singular Jacobian: stationary when even the
                        // damped step is below the tolerance.
                        Some(dx)
                            if matches!(gn, Step::Singular) && worst_of(&(lin.j * dx)) <= s.tolerance =>
                        {
                            converged = true;
                            break;
                        }
                        Some(dx) => dx,
                        None => {
                            mu *= T::lit(10.0);
                            used += 1;
                            if mu > mu_max {
                                break;
                            }
                            continue;
                        }
                    }
                }
            };
            used += 1;
            let trial = cur.x + dx;
            match self.evaluate(&trial, lengths, floor) {
                Some(pt) if pt.cost <= cur.cost * slack => {
                    cur = pt;
                    stale = true;
                    if mu > T::zero() {
                        mu /= T::lit(10.0);
                        if mu < mu_min {
                            mu = T::zero();
                        }
                    }
                }
                _ => {
                    mu = if mu == T::zero() { mu_min } else { mu * T::lit(10.0) };
                    if mu > mu_max {
                        break;
                    }
                }
            }
        }
        // At the cap, lengths beyond reach from the last step's point end
        // the run as inconsistent: it is near a least-squares minimum whose
        // residual no pose nearby brings under the consistency threshold
        // (the classification rejects it on its worst residual).
        if !converged && used >= s.max_iterations && beyond_reach {
            converged = true;
        }
        Some((RunEnd { point: cur, converged, condition }, used))
    }
}

enum Verdict {
    /// Consistent, inside the region.
    Accept,
    /// Consistent, on the right side, outside the box but within the
    /// robot's size of it.
    Outside,
    /// Not converged, inconsistent, or the mirror pose.
    Reject,
}

enum Step<T: Real, const N: usize> {
    Converged,
    /// The step, and whether the lengths are beyond reach from the point.
    Full(SVector<T, N>, bool),
    Singular,
}

/// The Gauss-Newton step `-(J^T J)^-1 J^T r`, or `Converged` when its
/// length change `|J dx|_inf` is within the tolerance, or within
/// `sqrt(eps)` of the residual `|r|_inf`: the decrease the step promises,
/// `|J dx|^2`, is then below the rounding of the sum of squares itself
/// (`eps |r|^2`), and the point is the least-squares minimum to the type's
/// precision. Consistent lengths meet the absolute test first (their
/// residual is rounding and noise).
///
/// A full step also says, when it is the run's `last` (its iteration
/// meets the cap), whether the lengths are beyond reach from the
/// point ([`Step::Full`]'s flag): the linear model's best worst residual,
/// at least the RMS of `r + J dx` (the step minimises its 2-norm, and
/// `|v|_inf >= |v|_2 / sqrt(M)`), exceeds twice the consistency threshold,
/// and the step changes no length by more than an eighth of that RMS (the
/// point is near a minimum, where the model holds). Lengths that no pose
/// has (a stretched, slack or broken cable) end at a large residual, where
/// Gauss-Newton converges only linearly and a run can meet the iteration
/// cap before the tests above: a run whose last step was beyond reach ends
/// inconsistent rather than unconverged (`Robot::run`).
fn gauss_newton<T: Real, const N: usize, const M: usize>(
    lin: &Linear<T, N, M>,
    r: &SVector<T, M>,
    s: &ForwardSettings<T>,
    last: bool,
) -> Step<T, N> {
    let Some(f) = &lin.factor else { return Step::Singular };
    let g = lin.j.tr_mul(r);
    let dx = -f.solve(&g);
    if !all_finite(dx.iter().copied()) {
        return Step::Singular;
    }
    let jdx = lin.j * dx;
    let change = worst_of(&jdx);
    if change <= s.tolerance || change <= T::eps().sqrt_native() * worst_of(r) {
        return Step::Converged;
    }
    if !last {
        return Step::Full(dx, false);
    }
    let beyond = T::lit(2.0) * s.consistency;
    let mean_square = (r + jdx).norm_squared() / T::lit(M as f64);
    Step::Full(dx, mean_square > beyond * beyond && T::lit(64.0) * change * change <= mean_square)
}

/// The damped step `-(J^T J + mu (diag(J^T J) + d))^-1 J^T r`, `d` a floor
/// of `eps` times the largest diagonal entry (so that a zero column is
/// damped too).
fn damped<T: Real, const N: usize, const M: usize>(
    lin: &Linear<T, N, M>,
    r: &SVector<T, M>,
    mu: T,
) -> Option<SVector<T, N>> {
    let mut a = lin.a;
    let mut dmax = T::zero();
    for k in 0..N {
        if a[(k, k)] > dmax {
            dmax = a[(k, k)];
        }
    }
    let d = T::eps() * dmax;
    for k in 0..N {
        let akk = a[(k, k)];
        a[(k, k)] = akk + mu * (akk + d);
    }
    let (f, _) = Ldl::factor(&a).ok()?;
    let dx = -f.solve(&lin.j.tr_mul(r));
    if all_finite(dx.iter().copied()) {
        Some(dx)
    } else {
        None
    }
}

/// How many cold starts the longest list has (spatial6, planar3).
const COLD_STARTS: usize = 13 + TILTS;

/// The tilted starts of `spatial6`.
const TILTS: usize = 4;

/// Octant `k` (0..8) as offsets of one quarter of the box.
fn octant(k: usize) -> [i8; 3] {
    let s = |bit: usize| if k & bit == 0 { -1 } else { 1 };
    [s(1), s(2), s(4)]
}

/// Quadrant `k` (0..4) in the plane.
fn quadrant(k: usize) -> [i8; 3] {
    let s = |bit: usize| if k & bit == 0 { -1 } else { 1 };
    [s(1), s(2), 0]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Platform, TensionLimits};

    fn planar_point() -> Robot<f64, 2, 4> {
        let anchors = [
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(3.0, 0.0, 0.0),
            Vector3::new(3.0, 3.0, 0.0),
            Vector3::new(0.0, 3.0, 0.0),
        ];
        let platform = Platform {
            mass: 1.0,
            com: Vector3::zeros(),
            gravity: Vector3::new(0.0, -9.81, 0.0),
            inertia: Matrix3::zeros(),
        };
        Robot::new(
            RobotKind::Planar2,
            anchors,
            [Vector3::zeros(); 4],
            TensionLimits::uniform(1.0, 10.0).unwrap(),
            platform,
            None,
        )
        .unwrap()
    }

    #[test]
    fn status_words() {
        let words = [
            (ForwardError::NonFinite, "nonfinite"),
            (ForwardError::UnsupportedShape, "unsupported-shape"),
            (ForwardError::NoConvergence, "no-convergence"),
            (ForwardError::IllConditioned, "ill-conditioned"),
            (ForwardError::InconsistentLengths, "inconsistent-lengths"),
        ];
        for (e, w) in words {
            assert_eq!(e.status(), w);
        }
    }

    #[test]
    fn wrap_keeps_angles_in_range() {
        for x in [-10.0f64, -3.5, -3.0, 0.0, 3.0, 3.5, 7.0, 100.0] {
            let y = wrap(x);
            assert!(y > -core::f64::consts::PI && y <= core::f64::consts::PI);
            assert!(
                ((x - y) / core::f64::consts::TAU - ((x - y) / core::f64::consts::TAU).round()).abs() < 1e-12
            );
        }
    }

    #[test]
    fn planar_point_round_trip() {
        let robot = planar_point();
        let settings = ForwardSettings::for_robot(&robot);
        let p = Vector3::new(1.0, 2.0, 0.0);
        let lengths = SVector::<f64, 4>::from_fn(|i, _| (robot.anchors()[i] - p).norm());
        let sol = robot.forward_kinematics(&lengths, None, &settings).unwrap();
        assert!((sol.pose[0] - 1.0).abs() < 1e-12 && (sol.pose[1] - 2.0).abs() < 1e-12);
        let warm = SVector::<f64, 2>::new(1.003, 1.998);
        let sol = robot.forward_kinematics(&lengths, Some(&warm), &settings).unwrap();
        assert!(!sol.cold_started);
        assert!((sol.pose[0] - 1.0).abs() < 1e-12 && (sol.pose[1] - 2.0).abs() < 1e-12);
    }
}

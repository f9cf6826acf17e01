//! Robot geometry, cable kinematics, the wrench matrix and the external
//! wrench, exactly as `docs/conventions.md` ("Poses", "Wrench matrix and equilibrium").
//!
//! * Pose `[x, y, z, rx, ry, rz]` (spatial6), `R = Rx(rx) Ry(ry) Rz(rz)`;
//!   `[x, y, theta]` (planar3); `[x, y]` (planar2, attachments ignored).
//! * Cable `i`: `l_i = a_i - p - R b_i`, `u_i = l_i / |l_i|`; column `i` of `W`
//!   is `[u_i; (R b_i) x u_i]` (spatial6), `[u_x, u_y, (R b)_x u_y - (R b)_y u_x]`
//!   (planar3) or `[u_x, u_y]` (planar2).
//! * Equilibrium `W t + w_e = 0`, so the methods solve `W t = f`, `f = -w_e`.

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

use crate::{
    scalar::{all_finite, finite, greater, max, min},
    tolerance, Error, Real, TensionLimits,
};

/// A pose: `N` numbers in the conventions' order for the robot's kind.
pub type Pose<T, const N: usize> = SVector<T, N>;

/// The robot's kind, which fixes its number of degrees of freedom.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RobotKind {
    /// 6 DOF, pose `[x, y, z, rx, ry, rz]`.
    Spatial6,
    /// 3 DOF in the plane, pose `[x, y, theta]`.
    Planar3,
    /// A point mass in the plane, pose `[x, y]`.
    Planar2,
}

impl RobotKind {
    /// Degrees of freedom `n`.
    pub const fn dof(self) -> usize {
        match self {
            RobotKind::Spatial6 => 6,
            RobotKind::Planar3 => 3,
            RobotKind::Planar2 => 2,
        }
    }

    /// The conventions' name (`spatial6`, `planar3`, `planar2`).
    pub const fn name(self) -> &'static str {
        match self {
            RobotKind::Spatial6 => "spatial6",
            RobotKind::Planar3 => "planar3",
            RobotKind::Planar2 => "planar2",
        }
    }

    /// Parses the conventions' name.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "spatial6" => Some(RobotKind::Spatial6),
            "planar3" => Some(RobotKind::Planar3),
            "planar2" => Some(RobotKind::Planar2),
            _ => None,
        }
    }
}

/// Mass properties of the platform (conventions: `[platform]`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Platform<T: Real> {
    /// Mass, kg (with payload).
    pub mass: T,
    /// Centre of mass `c`, platform frame, m.
    pub com: Vector3<T>,
    /// Gravity `g`, base frame, m/s^2.
    pub gravity: Vector3<T>,
    /// Inertia about the centre of mass, platform axes, kg m^2.
    pub inertia: Matrix3<T>,
}

/// Winch data for torque commands (conventions: `[winch]`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Winch<T: Real> {
    /// Drum radius, m.
    pub drum_radius: T,
    /// Motor turns per drum turn.
    pub gear_ratio: T,
    /// Efficiency in `(0, 1]`.
    pub efficiency: T,
    /// Largest motor torque, N m.
    pub torque_max: T,
}

/// A motor torque command and whether it was limited to `+-torque_max`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotorTorque<T: Real> {
    /// Commanded torque, N m, within `+-torque_max`.
    pub torque: T,
    /// `true` when the tension asked for more than `torque_max`.
    pub saturated: bool,
}

impl<T: Real> Winch<T> {
    /// Validates the winch data: every number finite and positive,
    /// efficiency at most 1.
    pub fn new(drum_radius: T, gear_ratio: T, efficiency: T, torque_max: T) -> Result<Self, Error> {
        if !all_finite([drum_radius, gear_ratio, efficiency, torque_max]) {
            return Err(Error::NonFinite);
        }
        if drum_radius <= T::zero()
            || gear_ratio <= T::zero()
            || efficiency <= T::zero()
            || efficiency > T::one()
            || torque_max <= T::zero()
        {
            return Err(Error::InvalidLimits);
        }
        Ok(Self { drum_radius, gear_ratio, efficiency, torque_max })
    }

    /// conventions: `tau = t * drum_radius / (gear_ratio * efficiency)`, never beyond
    /// `+-torque_max`; the limiting is reported, not hidden.
    pub fn motor_torque(&self, tension: T) -> Result<MotorTorque<T>, Error> {
        if !tension.is_finite() {
            return Err(Error::NonFinite);
        }
        let raw = tension * self.drum_radius / (self.gear_ratio * self.efficiency);
        // Plain comparisons (`f32::max`/`min` are libm calls on the M4F);
        // `raw` is finite here.
        let torque = min(max(raw, -self.torque_max), self.torque_max);
        Ok(MotorTorque { torque, saturated: torque != raw })
    }
}

/// `((sin a, cos a), (sin b, cos b))` of a spatial pose's first two angles.
type SinCos2<T> = ((T, T), (T, T));

/// A pose's position, rotation and [`SinCos2`].
type Frame<T> = (Vector3<T>, Matrix3<T>, SinCos2<T>);

/// Platform velocity and acceleration for the d'Alembert inertial wrench.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motion<T: Real> {
    /// Acceleration of the platform frame's origin `p''`, base frame, m/s^2.
    pub linear_acceleration: Vector3<T>,
    /// Angular velocity `omega`, base frame, rad/s.
    pub angular_velocity: Vector3<T>,
    /// Angular acceleration `alpha`, base frame, rad/s^2.
    pub angular_acceleration: Vector3<T>,
}

impl<T: Real> Motion<T> {
    /// At rest.
    pub fn rest() -> Self {
        Self {
            linear_acceleration: Vector3::zeros(),
            angular_velocity: Vector3::zeros(),
            angular_acceleration: Vector3::zeros(),
        }
    }

    /// From the time derivatives of a pose: first and second derivatives of
    /// `[x, y, z, rx, ry, rz]` (spatial6), `[x, y, theta]` (planar3) or
    /// `[x, y]` (planar2). For XYZ Euler angles `R = Rx(a) Ry(b) Rz(c)`:
    /// `omega = a' e_x + b' Rx(a) e_y + c' Rx(a) Ry(b) e_z` and `alpha` its
    /// time derivative.
    pub fn from_pose_derivatives<const N: usize>(
        kind: RobotKind,
        pose: &Pose<T, N>,
        velocity: &Pose<T, N>,
        acceleration: &Pose<T, N>,
    ) -> Result<Self, Error> {
        if N != kind.dof() {
            return Err(Error::UnsupportedShape);
        }
        if !all_finite(pose.iter().chain(velocity.iter()).chain(acceleration.iter()).copied()) {
            return Err(Error::NonFinite);
        }
        let angles = match kind {
            RobotKind::Spatial6 => (pose[3].sin_cos_native(), pose[4].sin_cos_native()),
            _ => ((T::zero(), T::one()), (T::zero(), T::one())), // not read
        };
        Ok(Self::from_derivatives(kind, angles, velocity, acceleration))
    }

    /// [`Self::from_pose_derivatives`] with the sines and cosines of the
    /// spatial pose's first two angles already computed (not read for the
    /// planar kinds), inputs already checked.
    fn from_derivatives<const N: usize>(
        kind: RobotKind,
        ((sa, ca), (sb, cb)): SinCos2<T>,
        velocity: &Pose<T, N>,
        acceleration: &Pose<T, N>,
    ) -> Self {
        let z = T::zero();
        match kind {
            RobotKind::Spatial6 => {
                let (da, db, dc) = (velocity[3], velocity[4], velocity[5]);
                let j1 = Vector3::new(T::one(), z, z);
                let j2 = Vector3::new(z, ca, sa);
                let j3 = Vector3::new(sb, -sa * cb, ca * cb);
                let dj2 = Vector3::new(z, -sa, ca) * da;
                let dj3 = Vector3::new(db * cb, -da * ca * cb + db * sa * sb, -da * sa * cb - db * ca * sb);
                Self {
                    linear_acceleration: Vector3::new(acceleration[0], acceleration[1], acceleration[2]),
                    angular_velocity: j1 * da + j2 * db + j3 * dc,
                    angular_acceleration: j1 * acceleration[3]
                        + j2 * acceleration[4]
                        + j3 * acceleration[5]
                        + dj2 * db
                        + dj3 * dc,
                }
            }
            RobotKind::Planar3 => Self {
                linear_acceleration: Vector3::new(acceleration[0], acceleration[1], z),
                angular_velocity: Vector3::new(z, z, velocity[2]),
                angular_acceleration: Vector3::new(z, z, acceleration[2]),
            },
            RobotKind::Planar2 => Self {
                linear_acceleration: Vector3::new(acceleration[0], acceleration[1], z),
                angular_velocity: Vector3::zeros(),
                angular_acceleration: Vector3::zeros(),
            },
        }
    }
}

/// Per-cable kinematics at one pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CableState<T: Real, const M: usize> {
    /// Cable lengths `|l_i|`, m.
    pub lengths: SVector<T, M>,
    /// Unit vectors `u_i`, the direction each cable pulls the platform.
    pub directions: [Vector3<T>; M],
    /// Attachment points in base axes, `R b_i` (relative to `p`).
    pub attachments: [Vector3<T>; M],
}

/// A cable robot with `N` degrees of freedom and `M` cables.
#[derive(Debug, Clone, PartialEq)]
pub struct Robot<T: Real, const N: usize, const M: usize> {
    kind: RobotKind,
    anchors: [Vector3<T>; M],
    attachments: [Vector3<T>; M],
    limits: TensionLimits<T, M>,
    platform: Platform<T>,
    winch: Option<Winch<T>>,
}

/// Whether a 3 x 3 matrix is symmetric and positive semi-definite, to the
/// rounding of its entries: symmetric within `1e3 eps` of its largest entry,
/// and every principal minor (three diagonal entries, three 2 x 2, the
/// determinant) at least minus that tolerance to the minor's power.
fn positive_semidefinite<T: Real>(a: &Matrix3<T>) -> bool {
    let size = a.amax();
    let tol = tolerance::equality(size);
    let sym = (0..3).all(|i| (0..3).all(|j| (a[(i, j)] - a[(j, i)]).abs() <= tol));
    let diag = (0..3).all(|i| a[(i, i)] >= -tol);
    let minors = [(0, 1), (0, 2), (1, 2)]
        .iter()
        .all(|&(i, j)| a[(i, i)] * a[(j, j)] - a[(i, j)] * a[(j, i)] >= -tol * size);
    sym && diag && minors && a.determinant() >= -tol * size * size
}

impl<T: Real, const N: usize, const M: usize> Robot<T, N, M> {
    /// A robot; [`Error::UnsupportedShape`] unless `N` is the kind's number of
    /// degrees of freedom and `M >= N`, [`Error::NonFinite`] for any
    /// non-finite number, [`Error::InvalidLimits`] for a negative mass or an
    /// inertia that is not symmetric positive semi-definite (a body's inertia
    /// about its centre of mass always is; within `1e3 eps` of its size).
    pub fn new(
        kind: RobotKind,
        anchors: [Vector3<T>; M],
        attachments: [Vector3<T>; M],
        limits: TensionLimits<T, M>,
        platform: Platform<T>,
        winch: Option<Winch<T>>,
    ) -> Result<Self, Error> {
        if N != kind.dof() || M < N {
            return Err(Error::UnsupportedShape);
        }
        let numbers = anchors
            .iter()
            .chain(attachments.iter())
            .flat_map(|v| v.iter().copied())
            .chain(platform.com.iter().copied())
            .chain(platform.gravity.iter().copied())
            .chain(platform.inertia.iter().copied())
            .chain([platform.mass]);
        if !all_finite(numbers) {
            return Err(Error::NonFinite);
        }
        if platform.mass < T::zero() || !positive_semidefinite(&platform.inertia) {
            return Err(Error::InvalidLimits);
        }
        Ok(Self { kind, anchors, attachments, limits, platform, winch })
    }

    /// The kind.
    pub fn kind(&self) -> RobotKind {
        self.kind
    }

    /// Tension limits.
    pub fn limits(&self) -> &TensionLimits<T, M> {
        &self.limits
    }

    /// Platform mass properties.
    pub fn platform(&self) -> &Platform<T> {
        &self.platform
    }

    /// Sets the platform mass properties (payload changes).
    pub fn set_platform(&mut self, platform: Platform<T>) -> Result<(), Error> {
        let copy = Self::new(self.kind, self.anchors, self.attachments, self.limits, platform, self.winch)?;
        *self = copy;
        Ok(())
    }

    /// Winch data, if the robot file has it.
    pub fn winch(&self) -> Option<&Winch<T>> {
        self.winch.as_ref()
    }

    /// The box the platform can be in, `(lo, hi)`, base frame, m: the
    /// anchors' bounding box (x, y for planar robots; z is 0), reaching
    /// along each axis gravity acts on to the base origin (the floor under
    /// a suspended robot). Where the anchors lie in one plane through the
    /// origin across that axis (within a tenth of the box's width, the
    /// forward kinematics' test: a suspended robot framed on its ceiling)
    /// it reaches as far as the box is wide to the side gravity points,
    /// where the platform hangs (conventions). Across gravity a cable pulls
    /// the platform towards its anchor, so the origin's place there does
    /// not count, nor does the frame's tilt: with gravity on two axes both
    /// reach the origin. The board's setpoint range (0.5 m wider) and
    /// `cdpr workspace`'s default frame are this box.
    pub fn platform_region(&self) -> (Vector3<T>, Vector3<T>) {
        let axes = if self.kind == RobotKind::Spatial6 { 3 } else { 2 };
        let (mut lo, mut hi) = (self.anchors[0], self.anchors[0]);
        for a in &self.anchors {
            lo = lo.inf(a);
            hi = hi.sup(a);
        }
        let mut widest = T::zero();
        for k in 0..axes {
            widest = max(widest, hi[k] - lo[k]);
        }
        let tenth = T::lit(0.1) * widest;
        for k in axes..3 {
            lo[k] = T::zero();
            hi[k] = T::zero();
        }
        for k in 0..axes {
            let g = self.platform.gravity[k];
            if g == T::zero() {
                continue;
            }
            let mid = (lo[k] + hi[k]) * T::lit(0.5);
            if hi[k] - lo[k] <= tenth && mid.abs() <= tenth {
                if g < T::zero() {
                    lo[k] -= widest;
                } else {
                    hi[k] += widest;
                }
            } else {
                lo[k] = min(lo[k], T::zero());
                hi[k] = max(hi[k], T::zero());
            }
        }
        (lo, hi)
    }

    /// Base anchors `a_i`.
    pub fn anchors(&self) -> &[Vector3<T>; M] {
        &self.anchors
    }

    /// Platform attachments `b_i` (platform frame).
    pub fn attachments(&self) -> &[Vector3<T>; M] {
        &self.attachments
    }

    /// Position `p` and rotation `R` of a pose (conventions, "Poses").
    pub fn frame(&self, pose: &Pose<T, N>) -> Result<(Vector3<T>, Matrix3<T>), Error> {
        self.frame_with_angles(pose).map(|(p, rot, _)| (p, rot))
    }

    /// [`Self::frame`] and the sines and cosines of the first two angles of
    /// a spatial pose (for [`Motion`]; not meaningful for the planar kinds).
    fn frame_with_angles(&self, pose: &Pose<T, N>) -> Result<Frame<T>, Error> {
        if !finite(pose.as_slice()) {
            return Err(Error::NonFinite);
        }
        let (z, one) = (T::zero(), T::one());
        let unused = ((z, one), (z, one));
        Ok(match self.kind {
            RobotKind::Spatial6 => {
                let (sa, ca) = pose[3].sin_cos_native();
                let (sb, cb) = pose[4].sin_cos_native();
                let (sc, cc) = pose[5].sin_cos_native();
                // Rx(a) Ry(b) Rz(c), multiplied out.
                let (sa_sb, ca_sb) = (sa * sb, ca * sb);
                let rot = Matrix3::new(
                    cb * cc,
                    -(cb * sc),
                    sb,
                    sa_sb * cc + ca * sc,
                    ca * cc - sa_sb * sc,
                    -(sa * cb),
                    sa * sc - ca_sb * cc,
                    ca_sb * sc + sa * cc,
                    ca * cb,
                );
                (Vector3::new(pose[0], pose[1], pose[2]), rot, ((sa, ca), (sb, cb)))
            }
            RobotKind::Planar3 => (Vector3::new(pose[0], pose[1], z), rotation_z(pose[2]), unused),
            RobotKind::Planar2 => (Vector3::new(pose[0], pose[1], z), Matrix3::identity(), unused),
        })
    }

    /// Cable vectors, lengths and directions at a pose.
    /// [`Error::DegenerateCable`] when a cable is shorter than
    /// `1000 eps` times the size of the robot (no direction).
    pub fn cables(&self, pose: &Pose<T, N>) -> Result<CableState<T, M>, Error> {
        let (p, rot) = self.frame(pose)?;
        self.cables_at(&p, &rot)
    }

    fn cables_at(&self, p: &Vector3<T>, rot: &Matrix3<T>) -> Result<CableState<T, M>, Error> {
        let p = *p;
        let planar = self.kind != RobotKind::Spatial6;
        let flatten = |v: Vector3<T>| {
            if planar {
                Vector3::new(v.x, v.y, T::zero())
            } else {
                v
            }
        };
        // Built element by element (`from_fn`): nothing zeroed first and
        // then copied in (two 192-byte copies on a host).
        let attachments: [Vector3<T>; M] = core::array::from_fn(|i| match self.kind {
            RobotKind::Planar2 => Vector3::zeros(),
            _ => flatten(rot * self.attachments[i]),
        });
        let anchors: [Vector3<T>; M] = core::array::from_fn(|i| flatten(self.anchors[i]));
        let vectors: [Vector3<T>; M] = core::array::from_fn(|i| anchors[i] - p - attachments[i]);
        let lengths = SVector::<T, M>::from_fn(|i, _| vectors[i].norm_squared().sqrt_native());
        let mut size = amax3(&p);
        for i in 0..M {
            size = max(max(size, amax3(&anchors[i])), amax3(&attachments[i]));
            if !finite(vectors[i].as_slice()) || !lengths[i].is_finite() {
                return Err(Error::NonFinite);
            }
        }
        // The directions once the size is known.
        let floor = tolerance::degenerate_length(size);
        if !lengths.iter().all(|&length| greater(length, floor)) {
            return Err(Error::DegenerateCable);
        }
        let directions = core::array::from_fn(|i| vectors[i] / lengths[i]);
        Ok(CableState { lengths, directions, attachments })
    }

    /// The wrench matrix `W` (`N x M`) at a pose (conventions).
    pub fn wrench_matrix(&self, pose: &Pose<T, N>) -> Result<SMatrix<T, N, M>, Error> {
        let cables = self.cables(pose)?;
        Ok(self.wrench_matrix_of(&cables))
    }

    /// The wrench matrix from already computed cable kinematics.
    pub fn wrench_matrix_of(&self, cables: &CableState<T, M>) -> SMatrix<T, N, M> {
        let mut w = SMatrix::zeros();
        for i in 0..M {
            let u = cables.directions[i];
            let rb = cables.attachments[i];
            match self.kind {
                RobotKind::Spatial6 => {
                    let m = rb.cross(&u);
                    for k in 0..3 {
                        w[(k, i)] = u[k];
                        w[(k + 3, i)] = m[k];
                    }
                }
                RobotKind::Planar3 => {
                    w[(0, i)] = u.x;
                    w[(1, i)] = u.y;
                    w[(2, i)] = rb.x * u.y - rb.y * u.x;
                }
                RobotKind::Planar2 => {
                    w[(0, i)] = u.x;
                    w[(1, i)] = u.y;
                }
            }
        }
        w
    }

    /// The external wrench `w_e` on the platform (conventions): gravity `m g` at the
    /// centre of mass `R c`, plus `extra`, plus with `motion` the d'Alembert
    /// inertial wrench `-(m a_c, I_w alpha + omega x I_w omega)`, where
    /// `a_c = p'' + alpha x R c + omega x (omega x R c)` and `I_w = R I R^T`.
    /// Like gravity, the inertial force acts at the centre of mass, so its
    /// moment about the platform origin, `R c x (-m a_c)`, is included.
    /// Moments are about the platform origin, as in `W`.
    pub fn external_wrench(
        &self,
        pose: &Pose<T, N>,
        extra: &SVector<T, N>,
        motion: Option<&Motion<T>>,
    ) -> Result<SVector<T, N>, Error> {
        let (_, rot) = self.frame(pose)?;
        self.external_wrench_at(&rot, extra, motion)
    }

    fn external_wrench_at(
        &self,
        rot: &Matrix3<T>,
        extra: &SVector<T, N>,
        motion: Option<&Motion<T>>,
    ) -> Result<SVector<T, N>, Error> {
        let rot = *rot;
        if !finite(extra.as_slice()) {
            return Err(Error::NonFinite);
        }
        let pf = &self.platform;
        let rc = match self.kind {
            RobotKind::Planar2 => Vector3::zeros(),
            _ => rot * pf.com,
        };
        let mut force = pf.gravity * pf.mass;
        let mut moment = rc.cross(&force);
        if let Some(motion) = motion {
            let numbers = motion
                .linear_acceleration
                .iter()
                .chain(motion.angular_velocity.iter())
                .chain(motion.angular_acceleration.iter())
                .copied();
            if !all_finite(numbers) {
                return Err(Error::NonFinite);
            }
            let omega = motion.angular_velocity;
            let alpha = motion.angular_acceleration;
            let a_c = motion.linear_acceleration + alpha.cross(&rc) + omega.cross(&omega.cross(&rc));
            let inertial_force = -a_c * pf.mass;
            let inertia_w = rot * pf.inertia * rot.transpose();
            force += inertial_force;
            moment += rc.cross(&inertial_force) - (inertia_w * alpha + omega.cross(&(inertia_w * omega)));
        }
        let mut w: SVector<T, N> = SVector::zeros();
        match self.kind {
            RobotKind::Spatial6 => {
                for k in 0..3 {
                    w[k] = force[k] + extra[k];
                    w[k + 3] = moment[k] + extra[k + 3];
                }
            }
            RobotKind::Planar3 => {
                w[0] = force.x + extra[0];
                w[1] = force.y + extra[1];
                w[2] = moment.z + extra[2];
            }
            RobotKind::Planar2 => {
                w[0] = force.x + extra[0];
                w[1] = force.y + extra[1];
            }
        }
        if finite(w.as_slice()) {
            Ok(w)
        } else {
            Err(Error::NonFinite)
        }
    }

    /// The wrench matrix and the wrench the cables must produce at a pose, in
    /// one pass: the frame (and its sines and cosines) is computed once.
    /// `derivatives` are the pose's first and second time derivatives, for the
    /// d'Alembert wrench ([`Motion::from_pose_derivatives`]); `None` for statics.
    /// The same as [`Self::wrench_matrix`] and [`Self::required_wrench`].
    pub fn wrench_problem(
        &self,
        pose: &Pose<T, N>,
        extra: &SVector<T, N>,
        derivatives: Option<(&Pose<T, N>, &Pose<T, N>)>,
    ) -> Result<(SMatrix<T, N, M>, SVector<T, N>), Error> {
        let (p, rot, angles) = self.frame_with_angles(pose)?;
        let cables = self.cables_at(&p, &rot)?;
        let motion = match derivatives {
            Some((velocity, acceleration)) => {
                if !all_finite(velocity.iter().chain(acceleration.iter()).copied()) {
                    return Err(Error::NonFinite);
                }
                Some(Motion::from_derivatives(self.kind, angles, velocity, acceleration))
            }
            None => None,
        };
        let f = -self.external_wrench_at(&rot, extra, motion.as_ref())?;
        Ok((self.wrench_matrix_of(&cables), f))
    }

    /// The wrench the cables must produce, `f = -w_e` (so that `W t = f`).
    pub fn required_wrench(
        &self,
        pose: &Pose<T, N>,
        extra: &SVector<T, N>,
        motion: Option<&Motion<T>>,
    ) -> Result<SVector<T, N>, Error> {
        Ok(-self.external_wrench(pose, extra, motion)?)
    }
}

fn rotation_z<T: Real>(a: T) -> Matrix3<T> {
    let (s, c) = a.sin_cos_native();
    let (o, l) = (T::zero(), T::one());
    Matrix3::new(c, -s, o, s, c, o, o, o, l)
}

/// `max_i |v_i|` by plain comparisons (nalgebra's `amax` calls `f32::max`,
/// a libm call on the M4F).
#[inline]
fn amax3<T: Real>(v: &Vector3<T>) -> T {
    max(max(v.x.abs(), v.y.abs()), v.z.abs())
}

//! The simulated robot: eight winches (current loop, torque limit,
//! friction, holding brake, encoder) on elastic cables that only pull,
//! and the platform as a 6-DOF rigid body under the cable forces, gravity
//! and an optional disturbance wrench. `f64` throughout, fixed-step
//! classical Runge-Kutta (RK4). `hal-sim/README.md` gives the equations
//! and the numbers.
//!
//! The plant implements `cdpr_control::WinchDrives`: the control loop
//! writes motor torque commands and the brake command straight into it
//! and reads its motor encoders (the paid-out length in counts, with the
//! robot file's counts per revolution and signs and an arbitrary offset
//! per drive, and the motor speed).

use cdpr_control::{WinchDrives, WinchReading, CABLES};
use nalgebra::{Matrix3, Quaternion, SVector, UnitQuaternion, Vector3};
use tension_core::{Error, Method, Robot, TensionSolver};

/// The plant's robot type (the robot file in `f64`).
pub type PlantRobot = Robot<f64, 6, CABLES>;

/// Winch and drive data beyond the conventions' `[winch]` table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WinchModel {
    /// Motor plus gearbox plus drum inertia, seen at the motor shaft, kg m^2.
    pub motor_inertia: f64,
    /// Coulomb friction torque at the motor shaft, N m.
    pub coulomb: f64,
    /// Speed (motor shaft, rad/s) over which the Coulomb friction is
    /// smoothed (`tanh(omega / omega_s)`).
    pub coulomb_speed: f64,
    /// Viscous friction at the motor shaft, N m s/rad.
    pub viscous: f64,
    /// Time constant of the drive's current (torque) loop, s.
    pub current_time_constant: f64,
    /// From the brake command to the drum locked (spring-applied brake), s.
    pub brake_engage_delay: f64,
    /// From the release command to the drum free, s.
    pub brake_release_delay: f64,
    /// Encoder counts per motor turn.
    pub encoder_counts: u32,
}

impl WinchModel {
    /// This model for a motor `k` times as strong: the inertia and the
    /// friction scaled by `k` (a smaller motor of the same family has a
    /// smaller rotor and smaller losses; the delays and the encoder are
    /// the same).
    pub fn scaled(self, k: f64) -> Self {
        Self {
            motor_inertia: self.motor_inertia * k,
            coulomb: self.coulomb * k,
            viscous: self.viscous * k,
            ..self
        }
    }

    /// The model used by every scenario on suspended-8 (see
    /// `hal-sim/README.md`; scaled by [`Self::scaled`] on other robots).
    pub const DEFAULT: Self = Self {
        motor_inertia: 1.4e-5,
        coulomb: 0.01,
        coulomb_speed: 0.5,
        viscous: 1.0e-4,
        current_time_constant: 0.2e-3,
        brake_engage_delay: 0.02,
        brake_release_delay: 0.02,
        encoder_counts: 4096,
    };
}

/// Cable data.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CableModel {
    /// Axial stiffness `E A`, N (a cable of unstretched length `L` has
    /// stiffness `E A / L`).
    pub ea: f64,
    /// Damping as a time constant: damping coefficient `beta k`, s.
    pub beta: f64,
}

impl CableModel {
    /// The model used by every scenario.
    pub const DEFAULT: Self = Self { ea: 4.0e5, beta: 1.0e-3 };
}

/// A wrench applied to the platform from `start` to `end` (s): force at the
/// platform origin and moment, base frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Disturbance {
    /// Start time, s.
    pub start: f64,
    /// End time, s.
    pub end: f64,
    /// `[fx, fy, fz, mx, my, mz]`, N and N m.
    pub wrench: [f64; 6],
}

/// Faults the plant can be given.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PlantFaults {
    /// Cable `i` breaks at time `t` (its tension is zero from then on).
    pub cable_break: Option<(usize, f64)>,
    /// From time `t`, drive `i` delivers at most `torque` N m; with
    /// `report` it flags a command beyond that as an error (the amplifier's
    /// current-limit output), otherwise it limits silently.
    pub derate: Option<Derate>,
    /// From time `t`, encoder `i` stops counting: its count and speed
    /// stay what they were at the first read from `t` on.
    pub encoder_stuck: Option<(usize, f64)>,
    /// From time `t`, drive `i` cannot be read (`read` returns
    /// `DriveError::Unreadable(i)`).
    pub unreadable: Option<(usize, f64)>,
}

/// A drive that can deliver less torque than commanded.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Derate {
    /// The drive.
    pub cable: usize,
    /// From this time, s.
    pub at: f64,
    /// Largest torque it delivers, N m.
    pub torque: f64,
    /// Whether it reports commands beyond that as an error.
    pub report: bool,
}

/// What differs between the simulated robot and the robot file.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mismatch {
    /// The simulated mass is the file's times this (payload error).
    pub mass_factor: f64,
    /// Added to the file's centre of mass, platform frame, m.
    pub com_offset: [f64; 3],
    /// Added to each of the file's base anchors `a_i`, base frame, m
    /// (geometric error: the frame as built is not the file's).
    pub anchor_offsets: [[f64; 3]; CABLES],
}

impl Mismatch {
    /// None: the plant is the robot file.
    pub const NONE: Self =
        Self { mass_factor: 1.0, com_offset: [0.0; 3], anchor_offsets: [[0.0; 3]; CABLES] };
}

/// A fixed pattern of anchor errors of length `magnitude` (m): anchor `i`
/// moves along the unit vector of `(cos(2.4 i + 0.3), sin(2.4 i + 0.3),
/// +-0.6)` (`+` for even `i`), so the errors point every way and do not
/// add up to a rigid shift of the frame.
pub fn anchor_offsets(magnitude: f64) -> [[f64; 3]; CABLES] {
    core::array::from_fn(|i| {
        let a = 2.4 * i as f64 + 0.3;
        let z = if i % 2 == 0 { 0.6 } else { -0.6 };
        let v = Vector3::new(a.cos(), a.sin(), z).normalize() * magnitude;
        [v.x, v.y, v.z]
    })
}

/// The drive error the plant reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DriveError {
    /// Drive `i` was asked for more torque than it can deliver.
    CurrentLimit(usize),
    /// A non-finite torque command for drive `i`.
    NonFinite(usize),
    /// Drive `i`'s encoder could not be read.
    Unreadable(usize),
}

/// The integrated state.
#[derive(Debug, Clone, Copy, PartialEq)]
struct State {
    /// Centre of mass, base frame, m.
    xc: Vector3<f64>,
    /// Its velocity, m/s.
    vc: Vector3<f64>,
    /// Orientation (renormalised after every step).
    q: Quaternion<f64>,
    /// Angular velocity, base frame, rad/s.
    w: Vector3<f64>,
    /// Unstretched cable length paid out by each winch, m.
    len: [f64; CABLES],
    /// Its rate (positive: paying out), m/s.
    rate: [f64; CABLES],
    /// Torque each motor delivers, N m.
    torque: [f64; CABLES],
}

impl State {
    fn add(&self, d: &State, h: f64) -> State {
        let mut s = *self;
        s.xc += d.xc * h;
        s.vc += d.vc * h;
        s.q += d.q * h;
        s.w += d.w * h;
        for i in 0..CABLES {
            s.len[i] += d.len[i] * h;
            s.rate[i] += d.rate[i] * h;
            s.torque[i] += d.torque[i] * h;
        }
        s
    }
}

/// One sample of the plant's true state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Pose of the platform frame `[x, y, z, rx, ry, rz]` (conventions).
    pub pose: [f64; 6],
    /// Velocity of the platform origin, base frame, m/s.
    pub velocity: Vector3<f64>,
    /// Angular velocity, base frame, rad/s.
    pub angular_velocity: Vector3<f64>,
    /// Cable tensions, N.
    pub tensions: [f64; CABLES],
    /// Whether the brakes hold the drums.
    pub locked: bool,
}

/// The simulated robot.
#[derive(Debug, Clone)]
pub struct Plant {
    robot: PlantRobot,
    winch: tension_core::Winch<f64>,
    model: WinchModel,
    cable: CableModel,
    faults: PlantFaults,
    mass: f64,
    com: Vector3<f64>,
    inertia: Matrix3<f64>,
    disturbances: Vec<Disturbance>,
    state: State,
    time: f64,
    dt: f64,
    command: [f64; CABLES],
    brake_command: bool,
    brake_since: f64,
    locked: bool,
    encoder: Encoders,
    /// The stuck encoder's frozen reading, once it stopped.
    stuck: Option<WinchReading>,
}

/// The motor encoders' counting: counts per motor turn, sign per cable
/// (`+1`: the count rises as the cable pays out) and the count at zero
/// paid-out length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Encoders {
    /// Counts per motor revolution.
    pub counts_per_revolution: u32,
    /// Sign per cable.
    pub signs: [i8; CABLES],
    /// Count at zero length per cable (arbitrary: a real encoder's count
    /// at power-up says nothing about the length).
    pub offsets: [i32; CABLES],
}

/// Pose `[x, y, z, rx, ry, rz]` of a rotation matrix and a position
/// (conventions: `R = Rx(rx) Ry(ry) Rz(rz)`).
pub fn pose_of(p: &Vector3<f64>, r: &Matrix3<f64>) -> [f64; 6] {
    let ry = r[(0, 2)].clamp(-1.0, 1.0).asin();
    let rx = (-r[(1, 2)]).atan2(r[(2, 2)]);
    let rz = (-r[(0, 1)]).atan2(r[(0, 0)]);
    [p.x, p.y, p.z, rx, ry, rz]
}

impl Plant {
    /// A plant of `robot` (the robot file, with a `[winch]` table) at rest
    /// at `pose` with the brakes holding it: each cable's paid-out length
    /// is set so that its stretch gives the barycenter tension of that
    /// pose for the simulated (possibly mismatched) platform. `dt` is the
    /// integration step, s.
    pub fn new(
        robot: PlantRobot,
        model: WinchModel,
        cable: CableModel,
        mismatch: Mismatch,
        pose: [f64; 6],
        dt: f64,
    ) -> Result<Self, Error> {
        let winch = *robot.winch().ok_or(Error::UnsupportedShape)?;
        let mut platform = *robot.platform();
        platform.mass *= mismatch.mass_factor;
        platform.com += Vector3::from(mismatch.com_offset);
        let mut anchors = *robot.anchors();
        for (a, d) in anchors.iter_mut().zip(&mismatch.anchor_offsets) {
            *a += Vector3::from(*d);
        }
        let true_robot = Robot::new(
            robot.kind(),
            anchors,
            *robot.attachments(),
            *robot.limits(),
            platform,
            robot.winch().copied(),
        )?;
        let pose_v = SVector::<f64, 6>::from(pose);
        let (w, f) = true_robot.wrench_problem(&pose_v, &SVector::zeros(), None)?;
        let tensions =
            TensionSolver::<f64, CABLES>::new(Method::Barycenter).solve(&w, &f, robot.limits())?.tensions;
        let cables = true_robot.cables(&pose_v)?;
        let (p, r) = true_robot.frame(&pose_v)?;
        let mut len = [0.0; CABLES];
        for i in 0..CABLES {
            // t = EA (l - L) / L  =>  L = EA l / (EA + t)
            len[i] = cable.ea * cables.lengths[i] / (cable.ea + tensions[i]);
        }
        let rot = nalgebra::Rotation3::from_matrix_unchecked(r);
        let state = State {
            xc: p + r * platform.com,
            vc: Vector3::zeros(),
            q: *UnitQuaternion::from_rotation_matrix(&rot).quaternion(),
            w: Vector3::zeros(),
            len,
            rate: [0.0; CABLES],
            torque: [0.0; CABLES],
        };
        Ok(Self {
            robot: true_robot,
            winch,
            model,
            cable,
            faults: PlantFaults::default(),
            mass: platform.mass,
            com: platform.com,
            inertia: platform.inertia,
            disturbances: Vec::new(),
            state,
            time: 0.0,
            dt,
            command: [0.0; CABLES],
            brake_command: true,
            brake_since: f64::NEG_INFINITY,
            locked: true,
            encoder: Encoders {
                counts_per_revolution: model.encoder_counts,
                signs: [1; CABLES],
                // Near the 32-bit wrap for some drives, so the loop's
                // wrapping arithmetic is exercised.
                offsets: core::array::from_fn(|i| (i as i32 - 4).wrapping_mul(0x1234_5677)),
            },
            stuck: None,
        })
    }

    /// Sets the faults to inject.
    pub fn set_faults(&mut self, faults: PlantFaults) {
        self.faults = faults;
    }

    /// Adds a disturbance wrench.
    pub fn add_disturbance(&mut self, d: Disturbance) {
        self.disturbances.push(d);
    }

    /// Makes now time 0 (the scripted faults, disturbances and the brake's
    /// engagement delay count from it): after a start-up phase that the
    /// script does not see.
    pub fn rebase_time(&mut self) {
        self.brake_since -= self.time;
        self.time = 0.0;
    }

    /// Simulated time, s.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// The simulated robot (with the mismatched platform).
    pub fn robot(&self) -> &PlantRobot {
        &self.robot
    }

    fn rotation(q: &Quaternion<f64>) -> Matrix3<f64> {
        UnitQuaternion::from_quaternion(*q).to_rotation_matrix().into_inner()
    }

    fn broken(&self, i: usize, t: f64) -> bool {
        matches!(self.faults.cable_break, Some((c, at)) if c == i && t >= at)
    }

    /// The torque drive `i` can deliver at time `t`, N m: zero or more,
    /// never NaN. A derate (or a winch limit) to a NaN or negative torque
    /// delivers nothing (`f64::min` would drop a NaN and deliver the full
    /// torque; `f64::clamp` by it would panic).
    fn torque_limit(&self, i: usize, t: f64) -> f64 {
        let limit = match self.faults.derate {
            Some(d) if d.cable == i && t >= d.at => {
                if d.torque > self.winch.torque_max {
                    self.winch.torque_max
                } else {
                    d.torque
                }
            }
            _ => self.winch.torque_max,
        };
        if limit >= 0.0 {
            limit
        } else {
            0.0
        }
    }

    /// Cable tensions and, for each, the unit vector and the attachment
    /// point relative to the centre of mass (base axes).
    fn cable_forces(
        &self,
        s: &State,
        t: f64,
    ) -> ([f64; CABLES], [Vector3<f64>; CABLES], [Vector3<f64>; CABLES]) {
        let r = Self::rotation(&s.q);
        let rc = r * self.com;
        let mut tensions = [0.0; CABLES];
        let mut dirs = [Vector3::zeros(); CABLES];
        let mut arms = [Vector3::zeros(); CABLES];
        for i in 0..CABLES {
            let arm = r * self.robot.attachments()[i] - rc;
            let l = self.robot.anchors()[i] - s.xc - arm;
            let length = l.norm();
            let u = l / length;
            let v_att = s.vc + s.w.cross(&arm);
            let length_rate = -u.dot(&v_att);
            let stretch = length - s.len[i];
            let k = self.cable.ea / s.len[i];
            let tension = if self.broken(i, t) || stretch <= 0.0 {
                0.0
            } else {
                (k * stretch + self.cable.beta * k * (length_rate - s.rate[i])).max(0.0)
            };
            tensions[i] = tension;
            dirs[i] = u;
            arms[i] = arm;
        }
        (tensions, dirs, arms)
    }

    fn disturbance(&self, t: f64) -> [f64; 6] {
        let mut w = [0.0; 6];
        for d in self.disturbances.iter().filter(|d| t >= d.start && t < d.end) {
            for (a, b) in w.iter_mut().zip(d.wrench) {
                *a += b;
            }
        }
        w
    }

    fn derivative(&self, s: &State, t: f64) -> State {
        let r = Self::rotation(&s.q);
        let (tensions, dirs, arms) = self.cable_forces(s, t);
        let mut force = self.robot.platform().gravity * self.mass;
        let mut moment = Vector3::zeros();
        for i in 0..CABLES {
            let f = dirs[i] * tensions[i];
            force += f;
            moment += arms[i].cross(&f);
        }
        let d = self.disturbance(t);
        let (fd, md) = (Vector3::new(d[0], d[1], d[2]), Vector3::new(d[3], d[4], d[5]));
        force += fd;
        // The force acts at the platform origin, -R c from the centre of mass.
        moment += md + (-(r * self.com)).cross(&fd);
        let inertia_w = r * self.inertia * r.transpose();
        let alpha =
            inertia_w.try_inverse().unwrap_or_else(Matrix3::zeros) * (moment - s.w.cross(&(inertia_w * s.w)));
        let omega = Quaternion::from_imag(s.w);
        let mut out = State {
            xc: s.vc,
            vc: force / self.mass,
            q: omega * s.q * 0.5,
            w: alpha,
            len: s.rate,
            rate: [0.0; CABLES],
            torque: [0.0; CABLES],
        };
        let (radius, gear, eta) = (self.winch.drum_radius, self.winch.gear_ratio, self.winch.efficiency);
        let mass_eq = self.model.motor_inertia * gear * gear / (radius * radius);
        for (i, &tension) in tensions.iter().enumerate() {
            // (The limit is zero or more: see `torque_limit`.)
            let limit = self.torque_limit(i, t);
            let target = self.command[i].clamp(-limit, limit);
            out.torque[i] = (target - s.torque[i]) / self.model.current_time_constant;
            if self.locked {
                out.len[i] = 0.0;
                continue;
            }
            let motor_speed = s.rate[i] * gear / radius;
            let friction = self.model.coulomb * (motor_speed / self.model.coulomb_speed).tanh()
                + self.model.viscous * motor_speed;
            let pull_in = s.torque[i] * gear * eta / radius;
            out.rate[i] = (tension - pull_in - friction * gear / radius) / mass_eq;
        }
        out
    }

    fn update_brakes(&mut self) {
        let since = self.time - self.brake_since;
        if self.brake_command && !self.locked && since >= self.model.brake_engage_delay - 1e-12 {
            self.locked = true;
        } else if !self.brake_command && self.locked && since >= self.model.brake_release_delay - 1e-12 {
            self.locked = false;
        }
        if self.locked {
            self.state.rate = [0.0; CABLES];
        }
    }

    /// Advances by `duration` s in RK4 steps of `dt` (the last one shorter
    /// if needed), holding the commands.
    pub fn advance(&mut self, duration: f64) {
        let end = self.time + duration;
        while self.time < end - 1e-12 {
            self.update_brakes();
            let h = self.dt.min(end - self.time);
            let t = self.time;
            let s = self.state;
            let k1 = self.derivative(&s, t);
            let k2 = self.derivative(&s.add(&k1, h / 2.0), t + h / 2.0);
            let k3 = self.derivative(&s.add(&k2, h / 2.0), t + h / 2.0);
            let k4 = self.derivative(&s.add(&k3, h), t + h);
            let mut next = s.add(&k1, h / 6.0).add(&k2, h / 3.0).add(&k3, h / 3.0).add(&k4, h / 6.0);
            next.q = next.q.normalize();
            self.state = next;
            self.time = end.min(t + h);
        }
        self.update_brakes();
    }

    /// The true state now.
    pub fn sample(&self) -> Sample {
        let s = &self.state;
        let r = Self::rotation(&s.q);
        let p = s.xc - r * self.com;
        let (tensions, _, _) = self.cable_forces(s, self.time);
        Sample {
            pose: pose_of(&p, &r),
            velocity: s.vc + s.w.cross(&(-(r * self.com))),
            angular_velocity: s.w,
            tensions,
            locked: self.locked,
        }
    }

    /// The encoders' counting (from the robot file's `[winch]`).
    pub fn set_encoders(&mut self, encoders: Encoders) {
        self.encoder = encoders;
    }

    /// The encoders' counting.
    pub fn encoders(&self) -> Encoders {
        self.encoder
    }

    /// The winch encoders' cable lengths (paid-out length, quantised to
    /// one encoder count), m.
    pub fn encoder_lengths(&self) -> [f64; CABLES] {
        let count = 2.0 * core::f64::consts::PI * self.winch.drum_radius
            / (self.winch.gear_ratio * f64::from(self.model.encoder_counts));
        self.state.len.map(|l| (l / count).round() * count)
    }
}

impl WinchDrives for Plant {
    type Error = DriveError;

    /// The paid-out length in counts (rounded, wrapping 32-bit) and the
    /// motor speed in counts per second; fails only with an injected
    /// unreadable drive (the other readings are still written), and a
    /// stuck encoder repeats its reading.
    fn read(&mut self, readings: &mut [WinchReading; CABLES]) -> Result<(), DriveError> {
        let e = &self.encoder;
        let count = 2.0 * core::f64::consts::PI * self.winch.drum_radius
            / (self.winch.gear_ratio * f64::from(e.counts_per_revolution));
        for (i, r) in readings.iter_mut().enumerate() {
            let s = f64::from(e.signs[i]);
            // Within +-2^31 counts (16 km of cable): the casts are exact.
            let counts = (s * self.state.len[i] / count).round() as i64;
            r.counts = e.offsets[i].wrapping_add(counts as i32);
            r.counts_per_second = (s * self.state.rate[i] / count).round() as i32;
        }
        if let Some((i, at)) = self.faults.encoder_stuck {
            if self.time >= at - 1e-12 {
                let frozen = *self
                    .stuck
                    .get_or_insert(WinchReading { counts: readings[i].counts, counts_per_second: 0 });
                readings[i] = frozen;
            }
        }
        match self.faults.unreadable {
            Some((i, at)) if self.time >= at - 1e-12 => Err(DriveError::Unreadable(i)),
            _ => Ok(()),
        }
    }

    fn failed_drive(&self, error: &DriveError) -> Option<usize> {
        match *error {
            DriveError::Unreadable(i) | DriveError::CurrentLimit(i) | DriveError::NonFinite(i) => Some(i),
        }
    }

    fn apply(&mut self, torques: &[f32; CABLES]) -> Result<(), DriveError> {
        let mut result = Ok(());
        for (i, &t) in torques.iter().enumerate() {
            if !t.is_finite() {
                self.command[i] = 0.0;
                result = Err(DriveError::NonFinite(i));
                continue;
            }
            self.command[i] = f64::from(t);
            let limit = self.torque_limit(i, self.time);
            let reports = matches!(self.faults.derate, Some(d) if d.cable == i && d.report);
            if reports && f64::from(t).abs() > limit && result.is_ok() {
                result = Err(DriveError::CurrentLimit(i));
            }
        }
        result
    }

    fn set_brakes(&mut self, engaged: bool) -> Result<(), DriveError> {
        if engaged != self.brake_command {
            self.brake_command = engaged;
            self.brake_since = self.time;
        }
        Ok(())
    }
}

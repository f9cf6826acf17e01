//! Reads the conventions' robot description files (TOML, `docs/conventions.md` "Robot
//! description files") into [`tension_core::Robot`] values.
//!
//! A file is parsed once into a [`RobotFile`] (any number of cables, `f64`),
//! then turned into a robot of a fixed size with [`RobotFile::to_robot`],
//! which checks that the kind and the number of cables fit `N x M`.

use std::ops::Range;
use std::path::Path;

use nalgebra::{Matrix3, SVector, Vector1, Vector3};
use serde::Deserialize;
use tension_core::{Platform, Real, Robot, RobotKind, TensionLimits, Winch};
use toml::Spanned;

/// A place in a robot file: 1-based line and, for errors about one value,
/// its 1-based column (in characters, as `toml` counts them).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Location {
    /// Line, from 1.
    pub line: usize,
    /// Column, from 1; `None` when the error is about the whole line (a key
    /// and its value, or a table header).
    pub column: Option<usize>,
}

impl Location {
    /// The line and column of byte `offset` in `text`.
    pub fn of_offset(text: &str, offset: usize) -> Self {
        let offset = offset.min(text.len());
        let before = &text.as_bytes()[..offset];
        let line_start = before.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
        let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
        let column = String::from_utf8_lossy(&before[line_start..]).chars().count() + 1;
        Self { line, column: Some(column) }
    }

    /// The line of the start of `span`, without a column.
    fn line_of(text: &str, span: Range<usize>) -> Self {
        Self { column: None, ..Self::of_offset(text, span.start) }
    }
}

/// What is wrong with a robot file.
#[derive(Debug)]
pub enum RobotFileErrorKind {
    /// The file could not be read.
    Io(std::io::Error),
    /// The TOML is malformed or does not follow the conventions' schema
    /// (`toml`'s message, without its source excerpt).
    Format(String),
    /// `kind` is none of the conventions' kinds.
    UnknownKind(String),
    /// A value `tension-core` rejects: what and where it is, and the error.
    Invalid(String, tension_core::Error),
    /// The robot's kind or cable count does not match the requested size.
    Shape {
        /// The file's kind.
        kind: RobotKind,
        /// The file's cables.
        cables: usize,
        /// Degrees of freedom asked for.
        dof: usize,
        /// Cables asked for.
        wanted_cables: usize,
    },
}

/// Why a robot file could not be used, and where in the file.
#[derive(Debug)]
pub struct RobotFileError {
    /// The file, when the error comes from [`RobotFile::load`].
    pub path: Option<String>,
    /// Where in the file, when the error is about one place.
    pub at: Option<Location>,
    /// What is wrong.
    pub kind: RobotFileErrorKind,
}

impl RobotFileError {
    fn new(kind: RobotFileErrorKind, at: Option<Location>) -> Self {
        Self { path: None, at, kind }
    }
}

impl std::fmt::Display for RobotFileErrorKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RobotFileErrorKind::Io(e) => write!(f, "{e}"),
            RobotFileErrorKind::Format(msg) => f.write_str(msg),
            RobotFileErrorKind::UnknownKind(kind) => {
                write!(f, "unknown kind `{kind}` (expected ")?;
                let names =
                    [RobotKind::Spatial6, RobotKind::Planar3, RobotKind::Planar2].map(RobotKind::name);
                write!(f, "{} or {})", names[..names.len() - 1].join(", "), names[names.len() - 1])
            }
            RobotFileErrorKind::Invalid(what, e) => write!(f, "{what} ({})", e.status()),
            RobotFileErrorKind::Shape { kind, cables, dof, wanted_cables } => write!(
                f,
                "robot is {} with {cables} cables, expected {dof} DOF with {wanted_cables} cables",
                kind.name()
            ),
        }
    }
}

/// `FILE, line L, column C: MESSAGE`, leaving out what is not known.
impl std::fmt::Display for RobotFileError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mut place = self.path.clone().unwrap_or_default();
        if let Some(at) = self.at {
            let sep = if place.is_empty() { "" } else { ", " };
            place.push_str(&format!("{sep}line {}", at.line));
            if let Some(c) = at.column {
                place.push_str(&format!(", column {c}"));
            }
        }
        if !place.is_empty() {
            write!(f, "{place}: ")?;
        }
        write!(f, "{}", self.kind)
    }
}

impl std::error::Error for RobotFileError {}

/// A number as a message shows it: as written (`12.5`, `0.05`) from
/// `1e-4` to below `1e9`, in exponent form beyond (`1e300`, `2.5e-7`);
/// either way the shortest digits that read back as the same `f64`. A
/// plain `{}` writes 301 digits for `1e300`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Readable(pub f64);

impl std::fmt::Display for Readable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let x = self.0;
        let plain = x == 0.0 || !x.is_finite() || (1e-4..1e9).contains(&x.abs());
        if plain {
            write!(f, "{x}")
        } else {
            write!(f, "{x:e}")
        }
    }
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct Limits {
    t_min: f64,
    t_max: f64,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct PlatformToml {
    mass: Spanned<f64>,
    #[serde(default)]
    com: Option<[f64; 3]>,
    gravity: [f64; 3],
    #[serde(default)]
    inertia: Option<[[f64; 3]; 3]>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct WinchToml {
    drum_radius: f64,
    gear_ratio: f64,
    efficiency: f64,
    torque_max: f64,
    #[serde(default)]
    counts_per_revolution: Option<Spanned<i64>>,
    #[serde(default)]
    encoder_sign: Option<Spanned<EncoderSignToml>>,
    #[serde(default)]
    rated_torque: Option<Spanned<f64>>,
    #[serde(default)]
    node_id: Option<Spanned<Vec<i64>>>,
    #[serde(default)]
    can_bus: Option<Spanned<Vec<i64>>>,
}

/// `[control]`: the board's feedback settings.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct ControlToml {
    #[serde(default)]
    bandwidth: Option<Spanned<f64>>,
}

/// `encoder_sign`: one sign for every cable, or one per cable.
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
enum EncoderSignToml {
    All(i64),
    PerCable(Vec<i64>),
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct CableToml {
    anchor: [f64; 3],
    attach: [f64; 3],
    #[serde(default)]
    t_min: Option<Spanned<f64>>,
    #[serde(default)]
    t_max: Option<Spanned<f64>>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct RobotToml {
    name: String,
    kind: Spanned<String>,
    limits: Spanned<Limits>,
    platform: Spanned<PlatformToml>,
    #[serde(default)]
    winch: Option<Spanned<WinchToml>>,
    #[serde(default)]
    control: Option<ControlToml>,
    cable: Vec<Spanned<CableToml>>,
}

/// The winches' motor encoders: cable `i`'s length is
/// `L_i = L_home_i + s_i * (counts_i - counts_home_i) * 2 pi r / (cpr * G)`
/// (`docs/conventions.md`, "Robot description files"), `r` the drum radius
/// and `G` the gear ratio of `[winch]`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EncoderSpec {
    /// Counts per motor revolution `cpr` (after quadrature decoding).
    pub counts_per_revolution: u32,
    /// `s_i` per cable, `+1` or `-1`: `+1` when the counts rise as the
    /// cable pays out (gets longer).
    pub signs: Vec<i8>,
}

impl EncoderSpec {
    /// Counts per motor revolution when the file does not say: a
    /// 1024-line incremental encoder read in quadrature.
    pub const DEFAULT_COUNTS_PER_REVOLUTION: u32 = 4096;
}

/// The winch drives on the board's CAN buses (CANopen CiA 402 servo
/// drives, `[winch]`'s `rated_torque`, `node_id` and `can_bus`; see
/// `docs/conventions.md`, "Robot description files").
#[derive(Debug, Clone, PartialEq)]
pub struct DriveSpec {
    /// The motors' rated torque, N m (the drives' object 0x6076, in which
    /// the target torque 0x6071 is written in thousandths); `None` when
    /// the file does not say (the CAN drives then refuse to start).
    pub rated_torque: Option<f64>,
    /// Cable `i`'s drive node id, 1..=127, unique on its bus.
    pub node_ids: Vec<u8>,
    /// Cable `i`'s bus: 1 (CAN1) or 2 (CAN2).
    pub buses: Vec<u8>,
    /// Whether the file set any of the three keys (only then do they enter
    /// [`RobotFile::canonical_bytes`]).
    pub explicit: bool,
}

impl DriveSpec {
    /// Drives two CAN buses address: node ids 1..=127 on each.
    pub const MAX_DRIVES: usize = 2 * 127;

    /// Each cable's bus as the board's CAN layer numbers them, from 0
    /// (CAN1 is 0).
    pub fn bus_indices(&self) -> Vec<u8> {
        self.buses.iter().map(|b| b.saturating_sub(1)).collect()
    }

    /// The default split of `cables` drives: the first half (rounded up) on
    /// CAN1 with node ids 1, 2, ..., the rest on CAN2 with node ids 1, 2,
    /// ...; `None` for more than [`Self::MAX_DRIVES`] (a bus would need an
    /// id above 127).
    pub fn default_split(cables: usize) -> Option<(Vec<u8>, Vec<u8>)> {
        if cables > Self::MAX_DRIVES {
            return None;
        }
        let first = cables.div_ceil(2);
        Some(
            (0..cables)
                .map(|i| if i < first { ((i + 1) as u8, 1) } else { ((i - first + 1) as u8, 2) })
                .unzip(),
        )
    }
}

/// One cable of a robot file.
#[derive(Debug, Clone, PartialEq)]
pub struct CableSpec {
    /// Base anchor `a_i`, base frame.
    pub anchor: [f64; 3],
    /// Platform attachment `b_i`, platform frame.
    pub attach: [f64; 3],
    /// Lower tension limit (file-wide value unless overridden).
    pub t_min: f64,
    /// Upper tension limit.
    pub t_max: f64,
}

/// A parsed robot file, any number of cables.
#[derive(Debug, Clone, PartialEq)]
pub struct RobotFile {
    /// `name`.
    pub name: String,
    /// `kind`.
    pub kind: RobotKind,
    /// Where `kind` is, for errors about the robot's shape.
    pub kind_at: Location,
    /// Platform mass, kg.
    pub mass: f64,
    /// Centre of mass, platform frame (zero when absent).
    pub com: [f64; 3],
    /// Gravity, base frame.
    pub gravity: [f64; 3],
    /// Inertia about the centre of mass (zero when absent: statics only).
    pub inertia: [[f64; 3]; 3],
    /// Winch data, when present.
    pub winch: Option<[f64; 4]>,
    /// The winches' motor encoders (`[winch]`'s `counts_per_revolution`
    /// and `encoder_sign`; the defaults when absent).
    pub encoder: EncoderSpec,
    /// The winch drives' bus addresses and rated torque (`[winch]`'s
    /// `rated_torque`, `node_id`, `can_bus`; defaults when absent).
    pub drives: DriveSpec,
    /// `[control] bandwidth`, Hz, when the file sets it: where the board's
    /// feedback puts its closed-loop poles ([`RobotFile::bandwidth_hz`]).
    pub bandwidth: Option<f64>,
    /// The cables in file order.
    pub cables: Vec<CableSpec>,
}

impl RobotFile {
    /// The board's feedback bandwidth when the file does not set
    /// `[control] bandwidth`, Hz (both feedback schemes' triple pole at
    /// `-2 pi 5` rad/s; `cdpr_control::control_loop::DEFAULT_OMEGA`).
    pub const DEFAULT_BANDWIDTH_HZ: f64 = 5.0;
    /// The largest `[control] bandwidth`, Hz: the board's loop runs at
    /// 1 kHz with up to 1.8 ms from a reading to its torque (a cycle and
    /// the CAN buses' 0.83 ms), which costs a triple pole at 20 Hz about
    /// 40 degrees of phase at its crossover (three times the pole).
    pub const MAX_BANDWIDTH_HZ: f64 = 20.0;

    /// The feedback's bandwidth, Hz: `[control] bandwidth`, or
    /// [`Self::DEFAULT_BANDWIDTH_HZ`]. Both of the board's feedback schemes
    /// place their three closed-loop poles per axis at `-2 pi bandwidth`
    /// (`cdpr_control::feedback::Gains::triple_pole`,
    /// `JointGains::triple_pole`). A heavy platform on heavy winches and
    /// long cables needs it lower than the default: its drums on its
    /// cables ring at a lower frequency.
    pub fn bandwidth_hz(&self) -> f64 {
        self.bandwidth.unwrap_or(Self::DEFAULT_BANDWIDTH_HZ)
    }

    /// Reads and parses a file; errors name the file.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, RobotFileError> {
        let path = path.as_ref();
        let named = |mut e: RobotFileError| {
            e.path = Some(path.display().to_string());
            e
        };
        let text = std::fs::read_to_string(path)
            .map_err(|e| named(RobotFileError::new(RobotFileErrorKind::Io(e), None)))?;
        Self::parse(&text).map_err(named)
    }

    /// Parses the TOML text of a robot file and checks its numbers with
    /// `tension-core`'s constructors, part by part, so that an error names
    /// the line of the part that is wrong.
    pub fn parse(text: &str) -> Result<Self, RobotFileError> {
        let raw: RobotToml = toml::from_str(text).map_err(|e| {
            let at = e.span().map(|s| Location::of_offset(text, s.start));
            RobotFileError::new(RobotFileErrorKind::Format(e.message().trim().to_string()), at)
        })?;
        // Every cable has a winch drive, and two CAN buses address 254
        // (checked first: the per-cable checks below compare the drives
        // pairwise).
        if let Some(extra) = raw.cable.get(DriveSpec::MAX_DRIVES) {
            let what = format!(
                "the file has {} cables; at most {} (a winch drive each, node ids 1..=127 on each of the two CAN buses)",
                raw.cable.len(),
                DriveSpec::MAX_DRIVES
            );
            return Err(RobotFileError::new(
                RobotFileErrorKind::Format(what),
                Some(Location::line_of(text, extra.span())),
            ));
        }
        let kind_at = Location::of_offset(text, raw.kind.span().start);
        let kind = RobotKind::from_name(raw.kind.get_ref()).ok_or_else(|| {
            RobotFileError::new(RobotFileErrorKind::UnknownKind(raw.kind.get_ref().clone()), Some(kind_at))
        })?;
        let limits = raw.limits.get_ref();
        let platform = raw.platform.get_ref();
        let file = Self {
            name: raw.name.clone(),
            kind,
            kind_at,
            mass: *platform.mass.get_ref(),
            com: platform.com.unwrap_or([0.0; 3]),
            gravity: platform.gravity,
            inertia: platform.inertia.unwrap_or([[0.0; 3]; 3]),
            winch: raw.winch.as_ref().map(|w| {
                let w = w.get_ref();
                [w.drum_radius, w.gear_ratio, w.efficiency, w.torque_max]
            }),
            encoder: encoder_spec(text, raw.winch.as_ref().map(Spanned::get_ref), raw.cable.len())?,
            drives: drive_spec(text, raw.winch.as_ref().map(Spanned::get_ref), raw.cable.len())?,
            bandwidth: bandwidth(text, raw.control.as_ref())?,
            cables: raw
                .cable
                .iter()
                .map(|c| {
                    let c = c.get_ref();
                    CableSpec {
                        anchor: c.anchor,
                        attach: c.attach,
                        t_min: c.t_min.as_ref().map_or(limits.t_min, |v| *v.get_ref()),
                        t_max: c.t_max.as_ref().map_or(limits.t_max, |v| *v.get_ref()),
                    }
                })
                .collect(),
        };
        file.check(text, &raw)?;
        Ok(file)
    }

    /// Each part through the `tension-core` constructor that accepts or
    /// rejects it; the rules live there, this only says where.
    fn check(&self, text: &str, raw: &RobotToml) -> Result<(), RobotFileError> {
        let invalid = |span: Range<usize>, what: String, e| {
            Err(RobotFileError::new(
                RobotFileErrorKind::Invalid(what, e),
                Some(Location::line_of(text, span)),
            ))
        };
        let platform = raw.platform.get_ref();
        if let Err(e) = probe_robot(self.platform(), [0.0; 3], [0.0; 3]) {
            let mass_ok = self.mass.is_finite() && self.mass >= 0.0;
            return if !mass_ok {
                let what = format!("[platform] mass = {} must be finite and >= 0", Readable(self.mass));
                invalid(platform.mass.span(), what, e)
            } else if e == tension_core::Error::InvalidLimits {
                let what = "[platform] inertia must be symmetric positive semi-definite".to_string();
                invalid(raw.platform.span(), what, e)
            } else {
                invalid(raw.platform.span(), "[platform] holds a number that is not finite".into(), e)
            };
        }
        if let (Some(w), Some(spanned)) = (self.winch, &raw.winch) {
            if let Err(e) = Winch::new(w[0], w[1], w[2], w[3]) {
                let what = "[winch]: drum_radius, gear_ratio, efficiency, torque_max must be positive, efficiency at most 1";
                return invalid(spanned.span(), what.into(), e);
            }
        }
        for (k, (c, spanned)) in self.cables.iter().zip(&raw.cable).enumerate() {
            if let Err(e) = probe_robot(self.platform(), c.anchor, c.attach) {
                return invalid(
                    spanned.span(),
                    format!("cable {}: anchor and attach must be finite", k + 1),
                    e,
                );
            }
            if let Err(e) = TensionLimits::new(Vector1::new(c.t_min), Vector1::new(c.t_max)) {
                let (t_min, t_max) = (Readable(c.t_min), Readable(c.t_max));
                let rule = if c.t_min >= 0.0 && c.t_min < c.t_max {
                    // In order, but too large: tension-core's other rule.
                    format!(
                        "limits t_min = {t_min}, t_max = {t_max}: t_max is too large (the methods' sums of \
                         squares of tensions must stay finite)"
                    )
                } else {
                    format!("limits t_min = {t_min}, t_max = {t_max} need 0 <= t_min < t_max")
                };
                let own = spanned.get_ref();
                return match own.t_min.as_ref().or(own.t_max.as_ref()) {
                    Some(value) => invalid(value.span(), format!("cable {}: {rule}", k + 1), e),
                    None => invalid(raw.limits.span(), format!("[limits]: {rule}"), e),
                };
            }
        }
        if self.cables.len() < self.dof() {
            return Err(RobotFileError::new(
                RobotFileErrorKind::Format(format!(
                    "a {} robot needs at least {} cables, the file has {}",
                    self.kind.name(),
                    self.dof(),
                    self.cables.len()
                )),
                None,
            ));
        }
        Ok(())
    }

    fn platform(&self) -> Platform<f64> {
        Platform {
            mass: self.mass,
            com: Vector3::from(self.com),
            gravity: Vector3::from(self.gravity),
            inertia: Matrix3::from_fn(|r, c| self.inertia[r][c]),
        }
    }

    /// Degrees of freedom of the robot's kind.
    pub fn dof(&self) -> usize {
        self.kind.dof()
    }

    /// A robot of fixed size `N x M` in scalar `T`; errors when the file's
    /// kind or number of cables differs, or a number is invalid.
    pub fn to_robot<T: Real, const N: usize, const M: usize>(
        &self,
    ) -> Result<Robot<T, N, M>, RobotFileError> {
        if self.kind.dof() != N || self.cables.len() != M {
            let shape = RobotFileErrorKind::Shape {
                kind: self.kind,
                cables: self.cables.len(),
                dof: N,
                wanted_cables: M,
            };
            return Err(RobotFileError::new(shape, Some(self.kind_at)));
        }
        let invalid = |what, e| RobotFileError::new(RobotFileErrorKind::Invalid(what, e), None);
        let v = |a: [f64; 3]| Vector3::new(T::lit(a[0]), T::lit(a[1]), T::lit(a[2]));
        let limits = TensionLimits::new(
            SVector::from_fn(|i, _| T::lit(self.cables[i].t_min)),
            SVector::from_fn(|i, _| T::lit(self.cables[i].t_max)),
        )
        .map_err(|e| invalid(format!("{}: [limits]", self.name), e))?;
        let winch = match self.winch {
            Some(w) => Some(
                Winch::new(T::lit(w[0]), T::lit(w[1]), T::lit(w[2]), T::lit(w[3]))
                    .map_err(|e| invalid(format!("{}: [winch]", self.name), e))?,
            ),
            None => None,
        };
        let platform = Platform {
            mass: T::lit(self.mass),
            com: v(self.com),
            gravity: v(self.gravity),
            inertia: Matrix3::from_fn(|r, c| T::lit(self.inertia[r][c])),
        };
        Robot::new(
            self.kind,
            core::array::from_fn(|i| v(self.cables[i].anchor)),
            core::array::from_fn(|i| v(self.cables[i].attach)),
            limits,
            platform,
            winch,
        )
        .map_err(|e| invalid(self.name.clone(), e))
    }
}

/// A robot's identity: its file's `name` and [`RobotFile::identity`]'s
/// hash of the parsed content.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct RobotIdentity {
    /// The file's `name`.
    pub name: String,
    /// FNV-1a 64 of the canonical serialisation of the parsed values.
    pub hash: u64,
}

/// `name#hash` with the hash as 16 hexadecimal digits.
impl std::fmt::Display for RobotIdentity {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}#{:016x}", self.name, self.hash)
    }
}

/// FNV-1a, 64 bits (offset basis 0xcbf29ce484222325, prime 0x100000001b3).
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    bytes
        .iter()
        .fold(0xcbf2_9ce4_8422_2325u64, |h, &b| (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3))
}

impl RobotFile {
    /// The canonical serialisation [`RobotFile::identity`] hashes: a
    /// version tag, then every parsed value in a fixed order, numbers as
    /// little-endian bytes (`f64` bits with `-0.0` as `0.0`), strings
    /// length-prefixed:
    /// `"cdpr-robot v1"`, `name`, `kind`'s conventions name, `mass`,
    /// `com`, `gravity`, `inertia` (row by row), whether there is a
    /// `[winch]` and its drum radius, gear ratio, efficiency, torque
    /// limit, `counts_per_revolution`, the number of cables, each
    /// cable's `encoder_sign`, anchor, attachment, `t_min`, `t_max`
    /// (per-cable limits as resolved: a file-wide limit and the same
    /// value repeated per cable are the same robot); then, only when the
    /// file sets them, the drives' keys and `[control] bandwidth`. Where a value comes
    /// from (defaults, overrides), whitespace, comments, key order and
    /// number spelling (`2`, `2.0`, `2e0`) do not enter it.
    pub fn canonical_bytes(&self) -> Vec<u8> {
        let mut out = Vec::new();
        let text = |out: &mut Vec<u8>, s: &str| {
            out.extend((s.len() as u64).to_le_bytes());
            out.extend(s.as_bytes());
        };
        let num = |out: &mut Vec<u8>, x: f64| out.extend((x + 0.0).to_bits().to_le_bytes());
        text(&mut out, "cdpr-robot v1");
        text(&mut out, &self.name);
        text(&mut out, self.kind.name());
        num(&mut out, self.mass);
        self.com
            .iter()
            .chain(&self.gravity)
            .chain(self.inertia.iter().flatten())
            .for_each(|&x| num(&mut out, x));
        match self.winch {
            Some(w) => {
                out.push(1);
                w.iter().for_each(|&x| num(&mut out, x));
            }
            None => out.push(0),
        }
        out.extend(self.encoder.counts_per_revolution.to_le_bytes());
        out.extend((self.cables.len() as u64).to_le_bytes());
        for (i, c) in self.cables.iter().enumerate() {
            out.push(self.encoder.signs.get(i).copied().unwrap_or(1) as u8);
            c.anchor.iter().chain(&c.attach).chain([&c.t_min, &c.t_max]).for_each(|&x| num(&mut out, x));
        }
        // The drives' keys only when the file sets one (files without
        // them keep the identity they had before the keys existed).
        if self.drives.explicit {
            text(&mut out, "drives v1");
            num(&mut out, self.drives.rated_torque.unwrap_or(f64::NAN));
            out.extend(&self.drives.node_ids);
            out.extend(&self.drives.buses);
        }
        // The feedback's bandwidth only when the file sets it (files
        // without it keep the identity they had before the key existed).
        if let Some(hz) = self.bandwidth {
            text(&mut out, "control v1");
            num(&mut out, hz);
        }
        out
    }

    /// The robot's identity: `name` and the FNV-1a 64 hash of
    /// [`RobotFile::canonical_bytes`]. The firmware's `build.rs` emits it
    /// as `firmware::robot::IDENTITY_HASH` and the board answers
    /// `HostMessage::Identify` with it.
    pub fn identity(&self) -> RobotIdentity {
        RobotIdentity { name: self.name.clone(), hash: fnv1a64(&self.canonical_bytes()) }
    }
}

/// `[control] bandwidth`, checked: finite, above 0 and at most
/// [`RobotFile::MAX_BANDWIDTH_HZ`].
fn bandwidth(text: &str, control: Option<&ControlToml>) -> Result<Option<f64>, RobotFileError> {
    let Some(value) = control.and_then(|c| c.bandwidth.as_ref()) else {
        return Ok(None);
    };
    let hz = *value.get_ref();
    if hz.is_finite() && hz > 0.0 && hz <= RobotFile::MAX_BANDWIDTH_HZ {
        return Ok(Some(hz));
    }
    let what = format!(
        "[control] bandwidth = {} Hz must be above 0 and at most {} (the board's 1 kHz loop and its delay)",
        Readable(hz),
        RobotFile::MAX_BANDWIDTH_HZ
    );
    Err(RobotFileError::new(
        RobotFileErrorKind::Format(what),
        Some(Location::of_offset(text, value.span().start)),
    ))
}

/// `[winch]`'s encoder keys, checked: `counts_per_revolution` a positive
/// integer that fits `u32`, `encoder_sign` `1` or `-1`, or a list of those
/// with one entry per cable.
fn encoder_spec(text: &str, winch: Option<&WinchToml>, cables: usize) -> Result<EncoderSpec, RobotFileError> {
    let format = |what: String, span: Range<usize>| {
        RobotFileError::new(RobotFileErrorKind::Format(what), Some(Location::of_offset(text, span.start)))
    };
    let counts_per_revolution = match winch.and_then(|w| w.counts_per_revolution.as_ref()) {
        None => EncoderSpec::DEFAULT_COUNTS_PER_REVOLUTION,
        Some(cpr) => u32::try_from(*cpr.get_ref()).ok().filter(|&c| c > 0).ok_or_else(|| {
            format(
                format!(
                    "[winch] counts_per_revolution = {} must be a positive integer below 2^32",
                    cpr.get_ref()
                ),
                cpr.span(),
            )
        })?,
    };
    let sign = |s: i64, span: Range<usize>| match s {
        1 => Ok(1i8),
        -1 => Ok(-1i8),
        _ => Err(format(format!("[winch] encoder_sign: {s} must be 1 or -1"), span)),
    };
    let signs = match winch.and_then(|w| w.encoder_sign.as_ref()) {
        None => vec![1; cables],
        Some(spanned) => match spanned.get_ref() {
            EncoderSignToml::All(s) => vec![sign(*s, spanned.span())?; cables],
            EncoderSignToml::PerCable(list) if list.len() == cables => {
                list.iter().map(|&s| sign(s, spanned.span())).collect::<Result<_, _>>()?
            }
            EncoderSignToml::PerCable(list) => {
                return Err(format(
                    format!("[winch] encoder_sign has {} entries, the file has {cables} cables", list.len()),
                    spanned.span(),
                ))
            }
        },
    };
    Ok(EncoderSpec { counts_per_revolution, signs })
}

/// `[winch]`'s drive keys, checked: `rated_torque` positive and finite,
/// with `torque_max` at most 32.767 times it (the target torque 0x6071 is
/// an `i16` in thousandths of it); `node_id` one id 1..=127 per cable and
/// `can_bus` one of 1 or 2 per cable, no two drives on one bus with the
/// same id.
fn drive_spec(text: &str, winch: Option<&WinchToml>, cables: usize) -> Result<DriveSpec, RobotFileError> {
    let format = |what: String, span: Range<usize>| {
        RobotFileError::new(RobotFileErrorKind::Format(what), Some(Location::of_offset(text, span.start)))
    };
    // `parse` refuses more cables than the buses address before this.
    let (default_ids, default_buses) = DriveSpec::default_split(cables).unwrap_or_default();
    let rated_torque = match winch.and_then(|w| w.rated_torque.as_ref()) {
        None => None,
        Some(r) => {
            let value = *r.get_ref();
            let torque_max = winch.map_or(f64::NAN, |w| w.torque_max);
            if !(value.is_finite() && value > 0.0) {
                return Err(format(
                    format!("[winch] rated_torque = {} must be positive and finite", Readable(value)),
                    r.span(),
                ));
            }
            if torque_max.is_nan() || torque_max / value * 1000.0 > f64::from(i16::MAX) {
                return Err(format(
                    format!("[winch] rated_torque = {}: torque_max = {} is over 32.767 times it (the drives' target torque is an i16 in thousandths of the rated torque)", Readable(value), Readable(torque_max)),
                    r.span(),
                ));
            }
            Some(value)
        }
    };
    let list = |key: &str,
                spanned: Option<&Spanned<Vec<i64>>>,
                range: std::ops::RangeInclusive<i64>,
                default: Vec<u8>| {
        match spanned {
            None => Ok(default),
            Some(s) if s.get_ref().len() != cables => Err(format(
                format!("[winch] {key} has {} entries, the file has {cables} cables", s.get_ref().len()),
                s.span(),
            )),
            Some(s) => s
                .get_ref()
                .iter()
                .map(|&v| {
                    if range.contains(&v) {
                        Ok(v as u8)
                    } else {
                        Err(format(
                            format!("[winch] {key}: {v} is not in {}..={}", range.start(), range.end()),
                            s.span(),
                        ))
                    }
                })
                .collect::<Result<Vec<u8>, _>>(),
        }
    };
    let node_ids = list("node_id", winch.and_then(|w| w.node_id.as_ref()), 1..=127, default_ids)?;
    let buses = list("can_bus", winch.and_then(|w| w.can_bus.as_ref()), 1..=2, default_buses)?;
    for i in 0..cables {
        for j in 0..i {
            if node_ids[i] == node_ids[j] && buses[i] == buses[j] {
                let span =
                    winch.and_then(|w| w.node_id.as_ref().or(w.can_bus.as_ref())).map_or(0..0, Spanned::span);
                return Err(format(
                    format!(
                        "[winch] cables {} and {} have the same node id {} on CAN{}",
                        j + 1,
                        i + 1,
                        node_ids[i],
                        buses[i]
                    ),
                    span,
                ));
            }
        }
    }
    let explicit =
        winch.is_some_and(|w| w.rated_torque.is_some() || w.node_id.is_some() || w.can_bus.is_some());
    Ok(DriveSpec { rated_torque, node_ids, buses, explicit })
}

/// `tension-core`'s checks of a platform and of one cable's geometry: a
/// one-DOF-short robot (planar2, the cable twice) built from them.
fn probe_robot(
    platform: Platform<f64>,
    anchor: [f64; 3],
    attach: [f64; 3],
) -> Result<(), tension_core::Error> {
    let limits = TensionLimits::uniform(0.0, 1.0)?;
    let (a, b) = (Vector3::from(anchor), Vector3::from(attach));
    Robot::<f64, 2, 2>::new(RobotKind::Planar2, [a; 2], [b; 2], limits, platform, None).map(|_| ())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_in_messages_stay_short_and_exact() {
        for (x, shown) in [
            (1e300, "1e300"),
            (-2.5e-7, "-2.5e-7"),
            (12.5, "12.5"),
            (0.05, "0.05"),
            (0.0, "0"),
            (999_999_999.0, "999999999"),
            (1e9, "1e9"),
            (f64::NAN, "NaN"),
            (f64::NEG_INFINITY, "-inf"),
        ] {
            let text = Readable(x).to_string();
            assert_eq!(text, shown);
            // The same f64 reads back.
            let back: f64 = text.parse().unwrap();
            assert!(back == x || (x.is_nan() && back.is_nan()), "{x}: {text}");
        }
        // A robot file's limit of 1e300 in the message as written, not in
        // 301 digits.
        let text = "name = \"t\"\nkind = \"planar2\"\n[limits]\nt_min = 5.0\nt_max = 1e300\n[platform]\nmass = 2.0\n\
                    gravity = [0.0, -9.81, 0.0]\n[[cable]]\nanchor = [0.0, 0.0, 0.0]\nattach = [0.0, 0.0, 0.0]\n\
                    [[cable]]\nanchor = [1.0, 0.0, 0.0]\nattach = [0.0, 0.0, 0.0]\n\
                    [[cable]]\nanchor = [1.0, 1.0, 0.0]\nattach = [0.0, 0.0, 0.0]\n";
        let e = RobotFile::parse(text).unwrap_err().to_string();
        assert!(e.contains("t_min = 5, t_max = 1e300: t_max is too large (") && e.len() < 160, "{e}");
    }

    #[test]
    fn per_cable_override_and_defaults() {
        let text = r#"
name = "t"
kind = "planar2"
[limits]
t_min = 1.0
t_max = 10.0
[platform]
mass = 2.0
gravity = [0.0, -9.81, 0.0]
[[cable]]
anchor = [0.0, 0.0, 0.0]
attach = [0.0, 0.0, 0.0]
t_min = 2.0
[[cable]]
anchor = [1.0, 0.0, 0.0]
attach = [0.0, 0.0, 0.0]
[[cable]]
anchor = [1.0, 1.0, 0.0]
attach = [0.0, 0.0, 0.0]
"#;
        let file = RobotFile::parse(text).unwrap();
        assert_eq!(file.cables[0].t_min, 2.0);
        assert_eq!(file.cables[1].t_min, 1.0);
        assert_eq!(file.com, [0.0; 3]);
        let robot = file.to_robot::<f64, 2, 3>().unwrap();
        assert_eq!(robot.limits().min()[0], 2.0);
        let shape = |e: RobotFileError| matches!(e.kind, RobotFileErrorKind::Shape { .. });
        assert!(shape(file.to_robot::<f64, 2, 4>().unwrap_err()));
        assert!(shape(file.to_robot::<f64, 3, 3>().unwrap_err()));
    }

    #[test]
    fn rejects_unknown_kind_fields_and_bad_limits() {
        let base = "name = \"t\"\nkind = \"planar2\"\n[limits]\nt_min = 1.0\nt_max = 10.0\n[platform]\nmass = 2.0\ngravity = [0.0, -9.81, 0.0]\n[[cable]]\nanchor = [0.0, 0.0, 0.0]\nattach = [0.0, 0.0, 0.0]\n";
        assert!(RobotFile::parse(&base.replace("planar2", "hexapod")).is_err());
        assert!(RobotFile::parse(&format!("{base}colour = 3\n")).is_err());
        let e = RobotFile::parse(&base.replace("t_min = 1.0", "t_min = 20.0")).unwrap_err();
        assert!(matches!(e.kind, RobotFileErrorKind::Invalid(..)));
    }

    /// `[winch]`'s encoder keys: defaults when absent, a scalar sign for
    /// every cable or one per cable, and errors that say where.
    #[test]
    fn encoder_keys() {
        let base = "name = \"t\"\nkind = \"planar2\"\n[limits]\nt_min = 1.0\nt_max = 10.0\n[platform]\nmass = 2.0\ngravity = [0.0, -9.81, 0.0]\n[winch]\ndrum_radius = 0.04\ngear_ratio = 8.0\nefficiency = 0.9\ntorque_max = 2.5\n[[cable]]\nanchor = [0.0, 0.0, 0.0]\nattach = [0.0, 0.0, 0.0]\n[[cable]]\nanchor = [1.0, 0.0, 0.0]\nattach = [0.0, 0.0, 0.0]\n";
        let default = RobotFile::parse(base).unwrap().encoder;
        assert_eq!(default, EncoderSpec { counts_per_revolution: 4096, signs: vec![1, 1] });
        let with = |keys: &str| {
            RobotFile::parse(&base.replace("torque_max = 2.5\n", &format!("torque_max = 2.5\n{keys}\n")))
        };
        let e = with("counts_per_revolution = 16384\nencoder_sign = -1").unwrap().encoder;
        assert_eq!(e, EncoderSpec { counts_per_revolution: 16384, signs: vec![-1, -1] });
        assert_eq!(with("encoder_sign = [1, -1]").unwrap().encoder.signs, vec![1, -1]);
        for bad in [
            "counts_per_revolution = 0",
            "counts_per_revolution = -5",
            "counts_per_revolution = 4294967296",
            "counts_per_revolution = 40.5",
            "encoder_sign = 2",
            "encoder_sign = [1, 0]",
            "encoder_sign = [1, -1, 1]",
        ] {
            let err = with(bad).unwrap_err();
            assert_eq!(err.at.map(|at| at.line), Some(14), "{bad}: {err}");
        }
        // No [winch]: the defaults, one sign per cable.
        let none = base.split("[winch]").next().unwrap().to_string()
            + &"[[cable]]\nanchor = [0.0, 0.0, 0.0]\nattach = [0.0, 0.0, 0.0]\n".repeat(3);
        assert_eq!(RobotFile::parse(&none).unwrap().encoder.signs, vec![1, 1, 1]);
    }

    /// `[control] bandwidth`: the default when absent, the value when set,
    /// each refusal with its line, and the identity: unchanged without the
    /// key (the shipped files' hashes stay), changed by any value.
    #[test]
    fn control_bandwidth() {
        let base = "name = \"t\"\nkind = \"planar2\"\n[limits]\nt_min = 1.0\nt_max = 10.0\n[platform]\nmass = 2.0\ngravity = [0.0, -9.81, 0.0]\n[[cable]]\nanchor = [0.0, 0.0, 0.0]\nattach = [0.0, 0.0, 0.0]\n[[cable]]\nanchor = [1.0, 0.0, 0.0]\nattach = [0.0, 0.0, 0.0]\n";
        let plain = RobotFile::parse(base).unwrap();
        assert_eq!((plain.bandwidth, plain.bandwidth_hz()), (None, 5.0));
        let with = |keys: &str| RobotFile::parse(&format!("{base}[control]\n{keys}\n"));
        let two = with("bandwidth = 2").unwrap();
        assert_eq!((two.bandwidth, two.bandwidth_hz()), (Some(2.0), 2.0));
        assert_eq!(with("bandwidth = 20.0").unwrap().bandwidth, Some(20.0));
        // An empty table is the default, and the same robot.
        assert_eq!(with("").unwrap().identity(), plain.identity());
        assert_ne!(two.identity(), plain.identity());
        assert_ne!(two.identity(), with("bandwidth = 2.5").unwrap().identity());
        assert_eq!(two.identity(), with("bandwidth = 2e0").unwrap().identity());
        for bad in
            ["bandwidth = 0", "bandwidth = -1.0", "bandwidth = 20.001", "bandwidth = nan", "bandwidth = inf"]
        {
            let err = with(bad).unwrap_err();
            assert_eq!(err.at.map(|at| at.line), Some(16), "{bad}: {err}");
            assert!(err.to_string().contains("[control] bandwidth"), "{bad}: {err}");
        }
        let err = with("gain = 3").unwrap_err();
        assert!(err.to_string().contains("unknown field `gain`"), "{err}");
    }

    /// `[winch]`'s drive keys: the default split over the two buses,
    /// explicit ids and buses, and each error with its line.
    #[test]
    fn drive_keys() {
        let base = "name = \"t\"\nkind = \"planar2\"\n[limits]\nt_min = 1.0\nt_max = 10.0\n[platform]\nmass = 2.0\ngravity = [0.0, -9.81, 0.0]\n[winch]\ndrum_radius = 0.04\ngear_ratio = 8.0\nefficiency = 0.9\ntorque_max = 2.5\n[[cable]]\nanchor = [0.0, 0.0, 0.0]\nattach = [0.0, 0.0, 0.0]\n[[cable]]\nanchor = [1.0, 0.0, 0.0]\nattach = [0.0, 0.0, 0.0]\n[[cable]]\nanchor = [1.0, 1.0, 0.0]\nattach = [0.0, 0.0, 0.0]\n";
        let default = RobotFile::parse(base).unwrap().drives;
        assert_eq!(
            default,
            DriveSpec { rated_torque: None, node_ids: vec![1, 2, 1], buses: vec![1, 1, 2], explicit: false }
        );
        // The board's CAN layer counts its buses from 0.
        assert_eq!(default.bus_indices(), vec![0, 0, 1]);
        assert_eq!(
            DriveSpec::default_split(8),
            Some((vec![1, 2, 3, 4, 1, 2, 3, 4], vec![1, 1, 1, 1, 2, 2, 2, 2]))
        );
        let (ids, buses) = DriveSpec::default_split(DriveSpec::MAX_DRIVES).unwrap();
        assert_eq!((ids[126], ids[127], ids[253]), (127, 1, 127));
        assert_eq!((buses[126], buses[127]), (1, 2));
        assert_eq!(DriveSpec::default_split(DriveSpec::MAX_DRIVES + 1), None);
        let with = |keys: &str| {
            RobotFile::parse(&base.replace("torque_max = 2.5\n", &format!("torque_max = 2.5\n{keys}\n")))
        };
        let d = with("rated_torque = 0.64\nnode_id = [5, 6, 5]\ncan_bus = [1, 1, 2]").unwrap().drives;
        assert_eq!(
            d,
            DriveSpec {
                rated_torque: Some(0.64),
                node_ids: vec![5, 6, 5],
                buses: vec![1, 1, 2],
                explicit: true
            }
        );
        for bad in [
            "rated_torque = 0.0",
            "rated_torque = -1.0",
            "rated_torque = 0.05",
            "node_id = [1, 2]",
            "node_id = [0, 1, 2]",
            "node_id = [1, 128, 2]",
            "can_bus = [1, 3, 2]",
            "node_id = [1, 1, 2]",
        ] {
            let err = with(bad).unwrap_err();
            assert_eq!(err.at.map(|at| at.line), Some(14), "{bad}: {err}");
        }
        // The same id on different buses is two drives.
        assert!(with("node_id = [1, 2, 2]\ncan_bus = [1, 1, 2]").is_ok());
        // The keys enter the identity only when set.
        let plain = RobotFile::parse(base).unwrap();
        assert_eq!(with("").unwrap().identity(), plain.identity());
        assert_ne!(with("rated_torque = 0.64").unwrap().identity(), plain.identity());
        assert_ne!(with("node_id = [1, 2, 3]\ncan_bus = [1, 1, 1]").unwrap().identity(), plain.identity());
    }

    /// FNV-1a 64's published test vectors.
    #[test]
    fn fnv1a64_vectors() {
        assert_eq!(fnv1a64(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a64(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a64(b"foobar"), 0x8594_4171_f739_67e8);
    }

    /// The identity depends on the parsed values only: reformatting,
    /// comments, key order, number spelling and a per-cable limit equal to
    /// the file-wide one leave it; any value changed (an anchor, a limit,
    /// the encoder, the name) changes it.
    #[test]
    fn identity_is_the_parsed_content() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let text = std::fs::read_to_string(root.join("robots/suspended-8.toml")).unwrap();
        let id = RobotFile::parse(&text).unwrap().identity();
        assert_eq!(id.name, "suspended-8");
        let same = |t: &str| RobotFile::parse(t).unwrap().identity();
        let reformatted = text
            .replace(" = ", "=")
            .replace("\n[", "\n\n# a comment\n[")
            .replace("t_max = 350.0", "t_max = 3.5e2")
            .replace("mass = 6.34", "mass = 6.340");
        assert_ne!(reformatted, text);
        assert_eq!(same(&reformatted), id);
        // Keys of a table in another order; the inertia written with integers.
        let reordered =
            text.replace("drum_radius = 0.04\ngear_ratio = 8.0", "gear_ratio = 8\ndrum_radius = 0.04");
        assert_eq!(same(&reordered), id);
        let explicit =
            text.replacen("attach = [0.2, -0.15, 0.15]", "attach = [0.2, -0.15, 0.15]\nt_max = 350", 1);
        assert_eq!(same(&explicit), id);
        let defaults = text
            .replace("torque_max = 2.5", "torque_max = 2.5\ncounts_per_revolution = 4096\nencoder_sign = 1");
        assert_eq!(same(&defaults), id);
        for changed in [
            text.replacen("anchor = [-2.0, -1.4, 3.5]", "anchor = [-2.0, -1.4, 3.4]", 1),
            text.replace("t_min = 5.0", "t_min = 5.5"),
            text.replace("torque_max = 2.5", "torque_max = 2.5\ncounts_per_revolution = 8192"),
            text.replace("torque_max = 2.5", "torque_max = 2.5\nencoder_sign = [1, 1, 1, 1, 1, 1, 1, -1]"),
            text.replace("name = \"suspended-8\"", "name = \"suspended-8b\""),
            text.replace("com = [0.0, 0.0, -0.1]", "com = [0.0, 0.0, -0.1000001]"),
        ] {
            assert_ne!(same(&changed), id, "{changed}");
        }
        let ipanema = RobotFile::load(root.join("robots/ipanema1.toml")).unwrap().identity();
        assert_ne!(ipanema.hash, id.hash);
        assert_eq!(format!("{ipanema}"), format!("ipanema1#{:016x}", ipanema.hash));
    }

    /// Errors carry `toml`'s span as a line and column, and the checks of
    /// `tension-core` the line of the part they reject.
    #[test]
    fn errors_say_where() {
        let base = "name = \"t\"\nkind = \"planar2\"\n[limits]\nt_min = 1.0\nt_max = 10.0\n[platform]\nmass = 2.0\ngravity = [0.0, -9.81, 0.0]\n[[cable]]\nanchor = [0.0, 0.0, 0.0]\nattach = [0.0, 0.0, 0.0]\n[[cable]]\nanchor = [1.0, 0.0, 0.0]\nattach = [0.0, 0.0, 0.0]\n";
        let at = |text: &str| RobotFile::parse(text).unwrap_err().at;
        let loc = |line, column| Some(Location { line, column });
        assert_eq!(at(&base.replace("t_max = 10.0", "t_max = \"10\"")), loc(5, Some(9)));
        assert_eq!(at(&base.replace("planar2", "hexapod")), loc(2, Some(8)));
        assert_eq!(at(&base.replace("t_min = 1.0", "t_min = 20.0")), loc(3, None));
        assert_eq!(at(&base.replace("mass = 2.0", "mass = -2.0")), loc(7, None));
        assert_eq!(at(&base.replace("gravity = [0.0, -9.81", "gravity = [0.0, nan")), loc(6, None));
        assert_eq!(
            at(&base.replacen("attach = [0.0, 0.0, 0.0]\n", "attach = [0.0, 0.0, inf]\n", 1)),
            loc(9, None)
        );
        let override_first =
            base.replacen("attach = [0.0, 0.0, 0.0]\n", "attach = [0.0, 0.0, 0.0]\nt_max = 0.5\n", 1);
        assert_eq!(at(&override_first), loc(12, None));
        assert_eq!(Location::of_offset("ab\ncé\nx", 7), Location { line: 3, column: Some(1) });
        assert_eq!(Location::of_offset("ab\ncé\nx", 6), Location { line: 2, column: Some(3) });
    }
}

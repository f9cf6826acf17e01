//! Reads the conventions' robot description files (TOML, `docs/conventions.md` "Robot
//! description files") into [`tension_core::Robot`] values.
//!
//! A file is parsed once into a [`RobotFile`] (any number of cables, `f64`),
//! then turned into a robot of a fixed size with [`RobotFile::to_robot`],
//! which checks that the kind and the number of cables fit `N x M`.

use std::path::Path;

use nalgebra::{Matrix3, SVector, Vector3};
use serde::Deserialize;
use tension_core::{Platform, Real, Robot, RobotKind, TensionLimits, Winch};

/// Why a robot file could not be used.
#[derive(Debug)]
pub enum RobotFileError {
    /// The file could not be read.
    Io(String, std::io::Error),
    /// The TOML does not follow the conventions' schema.
    Format(String),
    /// The numbers do not make a valid robot (see the inner error).
    Invalid(String, tension_core::Error),
    /// The robot's kind or cable count does not match the requested size.
    Shape { kind: RobotKind, cables: usize, dof: usize, wanted_cables: usize },
}

impl std::fmt::Display for RobotFileError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RobotFileError::Io(path, e) => write!(f, "{path}: {e}"),
            RobotFileError::Format(msg) => f.write_str(msg),
            RobotFileError::Invalid(what, e) => write!(f, "{what}: {e}"),
            RobotFileError::Shape { kind, cables, dof, wanted_cables } => write!(
                f,
                "robot is {} with {cables} cables, expected {dof} DOF with {wanted_cables} cables",
                kind.name()
            ),
        }
    }
}

impl std::error::Error for RobotFileError {}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct Limits {
    t_min: f64,
    t_max: f64,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct PlatformToml {
    mass: f64,
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
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct CableToml {
    anchor: [f64; 3],
    attach: [f64; 3],
    #[serde(default)]
    t_min: Option<f64>,
    #[serde(default)]
    t_max: Option<f64>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct RobotToml {
    name: String,
    kind: String,
    limits: Limits,
    platform: PlatformToml,
    #[serde(default)]
    winch: Option<WinchToml>,
    cable: Vec<CableToml>,
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
    /// The cables in file order.
    pub cables: Vec<CableSpec>,
}

impl RobotFile {
    /// Reads and parses a file.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, RobotFileError> {
        let path = path.as_ref();
        let text =
            std::fs::read_to_string(path).map_err(|e| RobotFileError::Io(path.display().to_string(), e))?;
        Self::parse(&text).map_err(|e| match e {
            RobotFileError::Format(msg) => RobotFileError::Format(format!("{}: {msg}", path.display())),
            other => other,
        })
    }

    /// Parses the TOML text of a robot file.
    pub fn parse(text: &str) -> Result<Self, RobotFileError> {
        let raw: RobotToml = toml::from_str(text).map_err(|e| RobotFileError::Format(e.to_string()))?;
        let kind = RobotKind::from_name(&raw.kind)
            .ok_or_else(|| RobotFileError::Format(format!("unknown kind `{}`", raw.kind)))?;
        if raw.cable.is_empty() {
            return Err(RobotFileError::Format("no [[cable]]".into()));
        }
        Ok(Self {
            name: raw.name,
            kind,
            mass: raw.platform.mass,
            com: raw.platform.com.unwrap_or([0.0; 3]),
            gravity: raw.platform.gravity,
            inertia: raw.platform.inertia.unwrap_or([[0.0; 3]; 3]),
            winch: raw.winch.map(|w| [w.drum_radius, w.gear_ratio, w.efficiency, w.torque_max]),
            cables: raw
                .cable
                .iter()
                .map(|c| CableSpec {
                    anchor: c.anchor,
                    attach: c.attach,
                    t_min: c.t_min.unwrap_or(raw.limits.t_min),
                    t_max: c.t_max.unwrap_or(raw.limits.t_max),
                })
                .collect(),
        })
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
            return Err(RobotFileError::Shape {
                kind: self.kind,
                cables: self.cables.len(),
                dof: N,
                wanted_cables: M,
            });
        }
        let v = |a: [f64; 3]| Vector3::new(T::lit(a[0]), T::lit(a[1]), T::lit(a[2]));
        let limits = TensionLimits::new(
            SVector::from_fn(|i, _| T::lit(self.cables[i].t_min)),
            SVector::from_fn(|i, _| T::lit(self.cables[i].t_max)),
        )
        .map_err(|e| RobotFileError::Invalid(format!("{}: [limits]", self.name), e))?;
        let winch = match self.winch {
            Some(w) => Some(
                Winch::new(T::lit(w[0]), T::lit(w[1]), T::lit(w[2]), T::lit(w[3]))
                    .map_err(|e| RobotFileError::Invalid(format!("{}: [winch]", self.name), e))?,
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
        .map_err(|e| RobotFileError::Invalid(self.name.clone(), e))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        assert!(matches!(file.to_robot::<f64, 2, 4>(), Err(RobotFileError::Shape { .. })));
        assert!(matches!(file.to_robot::<f64, 3, 3>(), Err(RobotFileError::Shape { .. })));
    }

    #[test]
    fn rejects_unknown_kind_fields_and_bad_limits() {
        let base = "name = \"t\"\nkind = \"planar2\"\n[limits]\nt_min = 1.0\nt_max = 10.0\n[platform]\nmass = 2.0\ngravity = [0.0, -9.81, 0.0]\n[[cable]]\nanchor = [0.0, 0.0, 0.0]\nattach = [0.0, 0.0, 0.0]\n";
        assert!(RobotFile::parse(&base.replace("planar2", "hexapod")).is_err());
        assert!(RobotFile::parse(&format!("{base}colour = 3\n")).is_err());
        let file = RobotFile::parse(&base.replace("t_min = 1.0", "t_min = 20.0")).unwrap();
        assert!(matches!(
            file.to_robot::<f64, 2, 1>(),
            Err(RobotFileError::Invalid(..)) | Err(RobotFileError::Shape { .. })
        ));
    }
}

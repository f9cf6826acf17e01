//! The typed error every fallible call returns.

/// Why no tension vector was returned. Each variant has a one-word status
/// ([`Error::status`]) used in the conventions' CSV tables and in telemetry.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Error {
    /// An input (pose, wrench, geometry, limits, warm start) holds NaN or an
    /// infinity, or a computation overflowed.
    NonFinite,
    /// Limits violate `0 <= t_min < t_max`, or barrier weights are not positive.
    InvalidLimits,
    /// No tension vector within the limits balances the wrench: the pose is
    /// outside the wrench-feasible workspace (certified, not guessed).
    Infeasible,
    /// The wrench matrix has lower rank than the number of degrees of freedom.
    Singular,
    /// A cable has (numerically) zero length, so it has no direction.
    DegenerateCable,
    /// The method needs another degree of redundancy (e.g. the barycenter
    /// needs `M = N + 2`), or the robot description does not fit `N x M`.
    UnsupportedShape,
    /// An iterative method hit its iteration cap without meeting its
    /// stopping rule, and infeasibility could not be certified either.
    NoConvergence,
    /// The method's answer leaves the limits although the pose may be
    /// feasible (closed form, improved closed form: Pott 2013, footnote 3).
    MethodFailed,
}

impl Error {
    /// Whether the error is a property of the problem that no other start
    /// would change (an `infeasible` certificate, invalid or non-finite
    /// input, a shape the method does not serve, a degenerate cable), as
    /// opposed to a method's numerical failure (`no-convergence`,
    /// `singular` pivots inside an iteration, `method-failed`).
    pub const fn is_certain(self) -> bool {
        matches!(
            self,
            Error::Infeasible | Error::InvalidLimits | Error::UnsupportedShape | Error::DegenerateCable
        )
    }

    /// The one-word status of the conventions' tension tables.
    pub fn status(self) -> &'static str {
        match self {
            Error::NonFinite => "nonfinite",
            Error::InvalidLimits => "invalid-limits",
            Error::Infeasible => "infeasible",
            Error::Singular => "singular",
            Error::DegenerateCable => "degenerate-cable",
            Error::UnsupportedShape => "unsupported-shape",
            Error::NoConvergence => "no-convergence",
            Error::MethodFailed => "method-failed",
        }
    }
}

impl core::fmt::Display for Error {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.status())
    }
}

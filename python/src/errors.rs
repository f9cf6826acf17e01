//! The package's exceptions: `CdprError` and one subclass per status word
//! of `docs/conventions.md` (tension distribution and forward kinematics),
//! each with its word as the class attribute `status` (and on the
//! instance), plus `RobotFileError` for a robot file or dict that cannot be
//! used.

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use tension_core::{Error, ForwardError};

create_exception!(
    cdpr,
    CdprError,
    PyException,
    "Base class of the errors of the cable robot core; `status` is the conventions' one-word reason."
);
create_exception!(
    cdpr,
    NonFiniteError,
    CdprError,
    "`nonfinite`: an input holds NaN or an infinity, or a computation overflowed."
);
create_exception!(
    cdpr,
    InvalidLimitsError,
    CdprError,
    "`invalid-limits`: limits violate 0 <= t_min < t_max (or a mass, inertia or winch value is invalid)."
);
create_exception!(
    cdpr,
    InfeasibleError,
    CdprError,
    "`infeasible`: no tensions within the limits balance the wrench (certified)."
);
create_exception!(
    cdpr,
    SingularError,
    CdprError,
    "`singular`: the wrench matrix has lower rank than the degrees of freedom."
);
create_exception!(
    cdpr,
    DegenerateCableError,
    CdprError,
    "`degenerate-cable`: a cable has (numerically) zero length."
);
create_exception!(
    cdpr,
    UnsupportedShapeError,
    CdprError,
    "`unsupported-shape`: the method does not serve the robot's degrees of freedom and cables."
);
create_exception!(
    cdpr,
    NoConvergenceError,
    CdprError,
    "`no-convergence`: an iterative method hit its cap; infeasibility not certified."
);
create_exception!(
    cdpr,
    MethodFailedError,
    CdprError,
    "`method-failed`: a closed form left the limits; feasibility unknown."
);
create_exception!(
    cdpr,
    IllConditionedError,
    CdprError,
    "`ill-conditioned` (forward kinematics): the Jacobian's condition is beyond the limit at the answer."
);
create_exception!(
    cdpr,
    InconsistentLengthsError,
    CdprError,
    "`inconsistent-lengths` (forward kinematics): no pose has these cable lengths."
);
create_exception!(cdpr, RobotFileError, CdprError, "A robot file or dict that cannot be used (the message names the line and column); `status` is the core's word when a value was rejected, else None.");

/// The status words of a tension table, `ok` first (the conventions'
/// list; the batches take each row's word from [`Error::status`] itself).
pub const SOLVE_STATUSES: [&str; 9] = [
    "ok",
    "nonfinite",
    "invalid-limits",
    "infeasible",
    "singular",
    "degenerate-cable",
    "unsupported-shape",
    "no-convergence",
    "method-failed",
];

/// The status words of a forward pose table, `ok` first.
pub const FORWARD_STATUSES: [&str; 6] =
    ["ok", "nonfinite", "unsupported-shape", "no-convergence", "ill-conditioned", "inconsistent-lengths"];

/// What each failure means, for the exception's message.
fn meaning(e: Error) -> &'static str {
    match e {
        Error::NonFinite => "an input holds NaN or an infinity, or a computation overflowed",
        Error::InvalidLimits => "the limits violate 0 <= t_min < t_max",
        Error::Infeasible => {
            "no tensions within the limits balance the wrench: the pose is outside the wrench-feasible workspace (certified)"
        }
        Error::Singular => "the wrench matrix has lower rank than the number of degrees of freedom",
        Error::DegenerateCable => "a cable has (numerically) zero length, so it has no direction",
        Error::UnsupportedShape => "the method does not serve this robot's degrees of freedom and cables",
        Error::NoConvergence => {
            "the method hit its iteration cap without meeting its stopping rule; infeasibility not certified"
        }
        Error::MethodFailed => "the method's answer leaves the limits although the pose may be feasible",
    }
}

/// The exception of a core error, `context: status: meaning`, with the
/// status on the instance.
pub fn core_error(py: Python<'_>, e: Error, context: &str) -> PyErr {
    let message = format!("{context}: {}: {}", e.status(), meaning(e));
    let err = match e {
        Error::NonFinite => NonFiniteError::new_err(message),
        Error::InvalidLimits => InvalidLimitsError::new_err(message),
        Error::Infeasible => InfeasibleError::new_err(message),
        Error::Singular => SingularError::new_err(message),
        Error::DegenerateCable => DegenerateCableError::new_err(message),
        Error::UnsupportedShape => UnsupportedShapeError::new_err(message),
        Error::NoConvergence => NoConvergenceError::new_err(message),
        Error::MethodFailed => MethodFailedError::new_err(message),
    };
    with_status(py, err, Some(e.status()))
}

/// The exception of a forward kinematics failure.
pub fn forward_error(py: Python<'_>, e: ForwardError, context: &str) -> PyErr {
    let what = match e {
        ForwardError::NonFinite => "a length, the guess or the geometry is not finite, or a length is negative",
        ForwardError::UnsupportedShape => "the robot's shape is not served",
        ForwardError::NoConvergence => "the iteration cap was hit (warm and cold starts)",
        ForwardError::IllConditioned => "the Jacobian is singular or ill-conditioned at the answer",
        ForwardError::InconsistentLengths => {
            "no pose of the robot has these lengths: the closest pose's worst residual is beyond the consistency threshold, or the lengths are beyond reach, or the only consistent pose lies farther from the robot than its size (a stretched, slack or broken cable, a wrong homing)"
        }
    };
    let message = format!("{context}: {}: {what}", e.status());
    let err = match e {
        ForwardError::NonFinite => NonFiniteError::new_err(message),
        ForwardError::UnsupportedShape => UnsupportedShapeError::new_err(message),
        ForwardError::NoConvergence => NoConvergenceError::new_err(message),
        ForwardError::IllConditioned => IllConditionedError::new_err(message),
        ForwardError::InconsistentLengths => InconsistentLengthsError::new_err(message),
    };
    with_status(py, err, Some(e.status()))
}

/// A [`RobotFileError`] with `message`, and the core's word when a value was
/// rejected.
pub fn robot_file_error(py: Python<'_>, message: String, status: Option<&'static str>) -> PyErr {
    with_status(py, RobotFileError::new_err(message), status)
}

/// Sets `status` on the exception instance (the class attribute stays).
fn with_status(py: Python<'_>, err: PyErr, status: Option<&'static str>) -> PyErr {
    // Setting an attribute on a fresh exception instance cannot fail in
    // practice; if it did, the exception is still raised, without it.
    let _ = err.value(py).setattr("status", status);
    err
}

/// Adds the exception classes to the module, each with its `status`.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    let classes = [
        ("CdprError", py.get_type::<CdprError>(), None),
        ("NonFiniteError", py.get_type::<NonFiniteError>(), Some("nonfinite")),
        ("InvalidLimitsError", py.get_type::<InvalidLimitsError>(), Some("invalid-limits")),
        ("InfeasibleError", py.get_type::<InfeasibleError>(), Some("infeasible")),
        ("SingularError", py.get_type::<SingularError>(), Some("singular")),
        ("DegenerateCableError", py.get_type::<DegenerateCableError>(), Some("degenerate-cable")),
        ("UnsupportedShapeError", py.get_type::<UnsupportedShapeError>(), Some("unsupported-shape")),
        ("NoConvergenceError", py.get_type::<NoConvergenceError>(), Some("no-convergence")),
        ("MethodFailedError", py.get_type::<MethodFailedError>(), Some("method-failed")),
        ("IllConditionedError", py.get_type::<IllConditionedError>(), Some("ill-conditioned")),
        ("InconsistentLengthsError", py.get_type::<InconsistentLengthsError>(), Some("inconsistent-lengths")),
        ("RobotFileError", py.get_type::<RobotFileError>(), None),
    ];
    for (name, class, status) in classes {
        class.setattr("status", status)?;
        m.add(name, class)?;
    }
    Ok(())
}

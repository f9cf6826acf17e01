"""Tension distribution, kinematics and workspace of cable-driven parallel robots.

The methods of the Rust ``tension-core`` (the project's firmware and host
tools run the same code), from Python with numpy arrays::

    import numpy as np
    import cdpr

    robot = cdpr.Robot.from_toml("robots/suspended-8.toml")
    tensions, status = robot.solve(np.array([[0, 0, 1.5, 0, 0, 0]]), method="barycenter")

Conventions (frames, XYZ Euler angles, the wrench matrix, method names,
status words, robot files) are the project's ``docs/conventions.md``.
"""

from ._native import (
    FORWARD_STATUSES,
    METHODS,
    SHAPES,
    STATUSES,
    CdprError,
    DegenerateCableError,
    IllConditionedError,
    InconsistentLengthsError,
    InfeasibleError,
    InvalidLimitsError,
    MethodFailedError,
    NoConvergenceError,
    NonFiniteError,
    Robot,
    RobotFileError,
    SingularError,
    UnsupportedShapeError,
)

__version__ = "0.1.0"

__all__ = [
    "FORWARD_STATUSES",
    "METHODS",
    "SHAPES",
    "STATUSES",
    "CdprError",
    "DegenerateCableError",
    "IllConditionedError",
    "InconsistentLengthsError",
    "InfeasibleError",
    "InvalidLimitsError",
    "MethodFailedError",
    "NoConvergenceError",
    "NonFiniteError",
    "Robot",
    "RobotFileError",
    "SingularError",
    "UnsupportedShapeError",
]

"""Type hints of the extension module ``cdpr._native`` (Rust, PyO3).

Arrays in: anything ``numpy.asarray`` takes with a real dtype (floating
point or integer, converted to float64), in any memory layout. Arrays out:
new C-contiguous float64 arrays (``bool`` for the workspace). Shapes: ``n``
is ``robot.dof``, ``m`` is ``robot.cables``, ``k`` the rows of a batch.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any, Literal, Optional, Tuple, Union, overload

import numpy as np
import numpy.typing as npt

ArrayLike = npt.ArrayLike
Float64Array = npt.NDArray[np.float64]

#: Every method name, in ``tension_core::Method::ALL`` order.
METHODS: Tuple[str, ...]
#: ``ok`` and the status words of a tension table (``docs/conventions.md``).
STATUSES: Tuple[str, ...]
#: ``ok`` and the status words of the forward kinematics.
FORWARD_STATUSES: Tuple[str, ...]
#: The (DOF, cables) shapes the package is built for.
SHAPES: Tuple[Tuple[int, int], ...]

class CdprError(Exception):
    """Base class of the core's errors; ``status`` is the one-word reason."""

    status: Optional[str]

class NonFiniteError(CdprError):
    """``nonfinite``: an input holds NaN or an infinity, or a computation overflowed."""

class InvalidLimitsError(CdprError):
    """``invalid-limits``: limits violate ``0 <= t_min < t_max``."""

class InfeasibleError(CdprError):
    """``infeasible``: no tensions within the limits balance the wrench (certified)."""

class SingularError(CdprError):
    """``singular``: the wrench matrix has lower rank than the degrees of freedom."""

class DegenerateCableError(CdprError):
    """``degenerate-cable``: a cable has (numerically) zero length."""

class UnsupportedShapeError(CdprError):
    """``unsupported-shape``: the method does not serve the robot's shape."""

class NoConvergenceError(CdprError):
    """``no-convergence``: an iterative method hit its cap; infeasibility not certified."""

class MethodFailedError(CdprError):
    """``method-failed``: a closed form left the limits; feasibility unknown."""

class IllConditionedError(CdprError):
    """``ill-conditioned`` (forward kinematics): the Jacobian is ill-conditioned at the answer."""

class InconsistentLengthsError(CdprError):
    """``inconsistent-lengths`` (forward kinematics): no pose has these lengths."""

class RobotFileError(CdprError):
    """A robot file or dict that cannot be used; ``status`` is the core's word
    when a value was rejected (``invalid-limits``, ``nonfinite``,
    ``unsupported-shape``), else None."""

class Robot:
    """A cable-driven parallel robot (``docs/conventions.md``)."""

    @staticmethod
    def from_toml(path: Union[str, os.PathLike[str]]) -> Robot:
        """Reads a robot file; ``RobotFileError`` names the file, line and column."""
    @staticmethod
    def from_dict(robot: Mapping[str, Any]) -> Robot:
        """A robot from a dict with the robot file's keys (``name``, ``kind``,
        ``limits``, ``platform``, optional ``winch``, ``cable``: a list of
        dicts with ``anchor``, ``attach`` and optional ``t_min``/``t_max``),
        parsed by the same parser as a file."""
    @property
    def name(self) -> str:
        """The robot file's ``name``."""
    @property
    def kind(self) -> str:
        """``spatial6``, ``planar3`` or ``planar2``."""
    @property
    def dof(self) -> int:
        """Degrees of freedom ``n`` (the pose's length)."""
    @property
    def cables(self) -> int:
        """Number of cables ``m``."""
    @property
    def pose_names(self) -> list[str]:
        """The pose's coordinate names (``x, y, z, rx, ry, rz`` / ``x, y, theta`` / ``x, y``)."""
    @property
    def methods(self) -> list[str]:
        """The methods that serve this robot's shape, in ``METHODS`` order."""
    @property
    def anchors(self) -> Float64Array:
        """Base anchors ``a_i``, base frame, m: ``(m, 3)``."""
    @property
    def attachments(self) -> Float64Array:
        """Platform attachments ``b_i``, platform frame, m: ``(m, 3)``."""
    @property
    def t_min(self) -> Float64Array:
        """Lower tension limits, N: ``(m,)``."""
    @property
    def t_max(self) -> Float64Array:
        """Upper tension limits, N: ``(m,)``."""
    @property
    def limits(self) -> Float64Array:
        """``(m, 2)``: columns ``t_min``, ``t_max``, N."""
    @property
    def mass(self) -> float:
        """Platform mass, kg."""
    @property
    def com(self) -> Float64Array:
        """Centre of mass, platform frame, m: ``(3,)``."""
    @property
    def gravity(self) -> Float64Array:
        """Gravity, base frame, m/s^2: ``(3,)``."""
    @property
    def inertia(self) -> Float64Array:
        """Inertia about the centre of mass, platform axes, kg m^2: ``(3, 3)``."""
    @property
    def winch(self) -> Optional[dict[str, float]]:
        """``drum_radius``, ``gear_ratio``, ``efficiency``, ``torque_max``, or None."""
    def wrench_matrix(self, pose: ArrayLike) -> Float64Array:
        """``W`` at one pose: ``(n, m)``."""
    def cable_lengths(self, pose: ArrayLike) -> Float64Array:
        """Cable lengths at one pose, m: ``(m,)``."""
    def required_wrench(
        self,
        pose: ArrayLike,
        wrench: Optional[ArrayLike] = None,
        velocity: Optional[ArrayLike] = None,
        acceleration: Optional[ArrayLike] = None,
    ) -> Float64Array:
        """``f = -w_e`` at one pose (gravity, extra wrench, d'Alembert): ``(n,)``."""
    def forward(self, lengths: ArrayLike, guess: Optional[ArrayLike] = None) -> Float64Array:
        """The pose from cable lengths ``(m,)``: ``(n,)``; raises the forward
        kinematics' errors."""
    def solve(
        self,
        poses: ArrayLike,
        method: str = "barycenter",
        wrenches: Optional[ArrayLike] = None,
        velocities: Optional[ArrayLike] = None,
        accelerations: Optional[ArrayLike] = None,
    ) -> Union[Float64Array, Tuple[Float64Array, npt.NDArray[np.str_]]]:
        """Tensions by ``method``.

        One pose ``(n,)``: the tensions ``(m,)``, or the core's exception
        (``InfeasibleError``, ...). A batch ``(k, n)``: ``(tensions,
        status)``, ``(k, m)`` with NaN rows where the status is not ``ok``
        and ``(k,)`` status words; warm-started along the rows, the GIL
        released. ``wrenches``, ``velocities``, ``accelerations``: ``(n,)``
        for every pose or ``(k, n)``.
        """
    @overload
    def motor_torques(self, tensions: ArrayLike, return_saturated: Literal[False] = ...) -> Float64Array:
        """Motor torques for ``(m,)`` or ``(k, m)`` tensions, N m, limited to
        ``+-torque_max``; NaN where a tension is not finite. With
        ``return_saturated=True``, ``(torques, saturated)``: ``True`` where
        the limit cut the torque."""
    @overload
    def motor_torques(
        self, tensions: ArrayLike, return_saturated: Literal[True]
    ) -> Tuple[Float64Array, npt.NDArray[np.bool_]]: ...
    def workspace_axes(
        self, step: float, bounds: Optional[ArrayLike] = None
    ) -> Tuple[Float64Array, ...]:
        """The cell centres along each axis of ``workspace``'s grid."""
    def workspace(
        self,
        step: float,
        method: Optional[str] = None,
        orientation: Optional[ArrayLike] = None,
        bounds: Optional[ArrayLike] = None,
        threads: Optional[int] = None,
    ) -> Tuple[npt.NDArray[np.bool_], float]:
        """The wrench-feasible workspace at a constant orientation, as ``cdpr
        workspace``: ``(feasible, volume)``, ``feasible`` ``(nz, ny, nx)``
        (spatial6) or ``(ny, nx)``, x fastest; the volume in m^3 (m^2 planar)."""

"""Every status word of the conventions reachable from Python: in a batch
as the row's word (no exception), for one pose as its exception class with
`status`; the words and classes exactly the conventions'."""

from __future__ import annotations

import copy

import numpy as np
import pytest

import cdpr

CONVENTIONS = [
    "nonfinite",
    "invalid-limits",
    "infeasible",
    "singular",
    "degenerate-cable",
    "unsupported-shape",
    "no-convergence",
    "method-failed",
]
CLASSES = {
    "nonfinite": cdpr.NonFiniteError,
    "invalid-limits": cdpr.InvalidLimitsError,
    "infeasible": cdpr.InfeasibleError,
    "singular": cdpr.SingularError,
    "degenerate-cable": cdpr.DegenerateCableError,
    "unsupported-shape": cdpr.UnsupportedShapeError,
    "no-convergence": cdpr.NoConvergenceError,
    "method-failed": cdpr.MethodFailedError,
}


def suspended_dict():
    return {
        "name": "s8",
        "kind": "spatial6",
        "limits": {"t_min": 5.0, "t_max": 350.0},
        "platform": {"mass": 6.34, "gravity": [0.0, 0.0, -9.81]},
        "cable": [
            {"anchor": [x, y, 3.5], "attach": [0.1 * np.sign(x), 0.1 * np.sign(y), 0.0]}
            for x, y in [(-2, -1.4), (-1.9, -1.5), (1.9, -1.5), (2, -1.4), (2, 1.4), (1.9, 1.5), (-1.9, 1.5), (-2, 1.4)]
        ],
    }


def test_words_and_classes_are_the_conventions():
    assert list(cdpr.STATUSES) == ["ok", *CONVENTIONS]
    assert list(cdpr.FORWARD_STATUSES) == [
        "ok",
        "nonfinite",
        "unsupported-shape",
        "no-convergence",
        "ill-conditioned",
        "inconsistent-lengths",
    ]
    for word, cls in CLASSES.items():
        assert cls.status == word
        assert issubclass(cls, cdpr.CdprError)
    assert cdpr.IllConditionedError.status == "ill-conditioned"
    assert cdpr.InconsistentLengthsError.status == "inconsistent-lengths"


# (robot, method, pose, extra wrench) for each word a solve returns.
def cases(robots):
    s8, p4 = robots["suspended-8"], robots["planar-point-4"]
    singular = copy.deepcopy(suspended_dict())
    for c in singular["cable"]:
        c["attach"] = [0.0, 0.0, 0.0]  # no moment: W has rank 3
    return {
        "ok": (s8, "barycenter", [0, 0, 1.5, 0, 0, 0], None),
        "nonfinite": (s8, "barycenter", [0, np.nan, 1.5, 0, 0, 0], None),
        "infeasible": (s8, "barycenter", [0, 0, 5.0, 0, 0, 0], None),
        "singular": (cdpr.Robot.from_dict(singular), "closed-form", [0, 0, 1.5, 0, 0, 0], None),
        "degenerate-cable": (p4, "barycenter", [0.0, 0.0], None),
        # Found by bisection on the extra wrench to the border of the
        # wrench-feasible set: tensions exist (min-2-norm finds them, 2e-11 N
        # from the limits) but Newton has no interior to centre in.
        "no-convergence": (p4, "analytic-centre", [1.5, 1.5], [298.7747468306154, 0.0]),
        "method-failed": (s8, "closed-form", [1.2, 0.8, 1.0, 0, 0, 0], None),
    }


def test_every_status_in_a_batch_and_as_an_exception(robots):
    seen = set()
    for word, (robot, method, pose, extra) in cases(robots).items():
        t, status = robot.solve(np.array([pose]), method=method, wrenches=extra)
        assert status.tolist() == [word], (word, status)
        if word == "ok":
            assert np.all(np.isfinite(t))
            assert robot.solve(pose, method=method, wrenches=extra).shape == (robot.cables,)
        else:
            assert np.all(np.isnan(t))
            with pytest.raises(CLASSES[word]) as info:
                robot.solve(pose, method=method, wrenches=extra)
            assert info.value.status == word
            assert word in str(info.value) and method in str(info.value)
        seen.add(word)
    # A batch mixing them: one status per row, nothing raised.
    rows = [c for c in cases(robots).values() if c[0] is robots["suspended-8"] and c[1] == "barycenter"]
    poses = np.array([r[2] for r in rows] * 3)
    t, status = robots["suspended-8"].solve(poses)
    assert status.tolist() == ["ok", "nonfinite", "infeasible"] * 3
    # unsupported-shape: a method that does not serve the robot is refused
    # before the batch starts (as `cdpr solve` refuses it).
    with pytest.raises(cdpr.UnsupportedShapeError, match="barycenter needs m = n \\+ 2") as info:
        robots["spatial6-10"].solve(np.zeros((3, 6)), method="barycenter")
    assert info.value.status == "unsupported-shape"
    seen.add("unsupported-shape")
    # invalid-limits: limits are checked when the robot is built.
    bad = suspended_dict()
    bad["limits"] = {"t_min": 50.0, "t_max": 5.0}
    with pytest.raises(cdpr.RobotFileError, match="t_min < t_max") as info:
        cdpr.Robot.from_dict(bad)
    assert info.value.status == "invalid-limits"
    seen.add("invalid-limits")
    assert seen == {"ok", *CONVENTIONS}


def test_forward_kinematics_statuses(robots):
    robot = robots["suspended-8"]
    lengths = robot.cable_lengths([0.1, 0.2, 1.5, 0.0, 0.0, 0.1])
    with pytest.raises(cdpr.NonFiniteError) as info:
        robot.forward(np.where(np.arange(8) == 2, np.nan, lengths))
    assert info.value.status == "nonfinite"
    with pytest.raises(cdpr.InconsistentLengthsError, match="worst residual") as info:
        robot.forward(lengths * np.array([1, 1, 1, 1, 1, 1, 1, 1.05]))
    assert info.value.status == "inconsistent-lengths"

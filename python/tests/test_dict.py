"""`Robot.from_dict`: the robot file's keys, through the same parser."""

from __future__ import annotations

import numpy as np
import pytest

import cdpr
from conftest import ROBOT_FILES
from reference import random_poses

try:
    import tomllib
except ImportError:  # Python < 3.11
    tomllib = None


def as_dict(robot: cdpr.Robot) -> dict:
    """A robot's dict from its accessors (numpy arrays as values)."""
    d = {
        "name": robot.name,
        "kind": robot.kind,
        "limits": {"t_min": float(robot.t_min[0]), "t_max": float(robot.t_max[0])},
        "platform": {"mass": robot.mass, "com": robot.com, "gravity": robot.gravity, "inertia": robot.inertia},
        "cable": [
            {"anchor": a, "attach": b, "t_min": lo, "t_max": hi}
            for a, b, lo, hi in zip(robot.anchors, robot.attachments, robot.t_min, robot.t_max)
        ],
    }
    if robot.winch is not None:
        d["winch"] = robot.winch
    return d


@pytest.mark.parametrize("stem", sorted(ROBOT_FILES))
def test_dict_of_a_robot_is_the_same_robot(robots, stem):
    robot = robots[stem]
    twin = cdpr.Robot.from_dict(as_dict(robot))
    for attr in ["kind", "dof", "cables", "mass", "methods", "pose_names", "winch"]:
        assert getattr(twin, attr) == getattr(robot, attr), attr
    for attr in ["anchors", "attachments", "limits", "com", "gravity", "inertia"]:
        np.testing.assert_array_equal(getattr(twin, attr), getattr(robot, attr), err_msg=attr)
    poses = random_poses(robot, 50, np.random.default_rng(4))
    for method in robot.methods[:3]:
        np.testing.assert_array_equal(twin.solve(poses, method=method)[0], robot.solve(poses, method=method)[0])


@pytest.mark.skipif(tomllib is None, reason="tomllib needs Python 3.11")
@pytest.mark.parametrize("stem", sorted(ROBOT_FILES))
def test_the_files_own_dict(robots, stem):
    """The file read by Python's TOML parser and given as a dict: every key
    the file has (optional ones included) is taken as the file takes it."""
    with open(ROBOT_FILES[stem], "rb") as fh:
        d = tomllib.load(fh)
    twin = cdpr.Robot.from_dict(d)
    np.testing.assert_array_equal(twin.limits, robots[stem].limits)
    np.testing.assert_array_equal(twin.anchors, robots[stem].anchors)


def test_plain_python_values_and_integers():
    d = {
        "name": "point",
        "kind": "planar2",
        "limits": {"t_min": 1, "t_max": 100},
        "platform": {"mass": 2, "gravity": (0, -9.81, 0)},
        "cable": [{"anchor": [x, y, 0], "attach": [0, 0, 0]} for x, y in [(0, 0), (2, 0), (2, 2), (0, 2)]],
        "winch": {"drum_radius": 0.05, "gear_ratio": 10, "efficiency": 1, "torque_max": 5, "encoder_sign": [1, -1, 1, -1]},
    }
    robot = cdpr.Robot.from_dict(d)
    assert (robot.kind, robot.dof, robot.cables, robot.mass) == ("planar2", 2, 4, 2.0)
    t = robot.solve([1.0, 1.0])
    assert np.all((t >= 1) & (t <= 100))
    assert robot.winch["gear_ratio"] == 10.0


def test_dict_errors():
    good = {
        "name": "point",
        "kind": "planar2",
        "limits": {"t_min": 1.0, "t_max": 100.0},
        "platform": {"mass": 2.0, "gravity": [0.0, -9.81, 0.0]},
        "cable": [{"anchor": [float(x), float(y), 0.0], "attach": [0.0, 0.0, 0.0]} for x, y in [(0, 0), (2, 0), (2, 2), (0, 2)]],
    }
    with pytest.raises(TypeError, match="expected a dict"):
        cdpr.Robot.from_dict([1, 2])
    bad = dict(good, platform={"mass": {1, 2}, "gravity": [0.0, -9.81, 0.0]})
    with pytest.raises(TypeError, match="`platform.mass` holds set"):
        cdpr.Robot.from_dict(bad)
    bad = dict(good, limits={"t_min": 1.0})
    with pytest.raises(cdpr.RobotFileError, match="missing field `t_max`"):
        cdpr.Robot.from_dict(bad)
    bad = dict(good, colour="red")
    with pytest.raises(cdpr.RobotFileError, match="unknown field `colour`"):
        cdpr.Robot.from_dict(bad)
    bad = dict(good, kind="planar9")
    with pytest.raises(cdpr.RobotFileError, match=r"unknown kind `planar9`.*\(at `kind = \"planar9\"` of the dict written as TOML\)"):
        cdpr.Robot.from_dict(bad)
    bad = dict(good, platform={"mass": -1.0, "gravity": [0.0, -9.81, 0.0]})
    with pytest.raises(cdpr.RobotFileError, match="mass = -1 must be finite and >= 0") as info:
        cdpr.Robot.from_dict(bad)
    assert info.value.status == "invalid-limits"
    bad = dict(good, platform={"mass": float("nan"), "gravity": [0.0, -9.81, 0.0]})
    with pytest.raises(cdpr.RobotFileError, match="must be finite") as info:
        cdpr.Robot.from_dict(bad)
    assert info.value.status == "nonfinite"
    bad = dict(good, cable=good["cable"][:1])
    with pytest.raises(cdpr.RobotFileError, match="needs at least 2 cables"):
        cdpr.Robot.from_dict(bad)
    bad = dict(good, cable=good["cable"] * 4)  # 16 cables: not a shape the package is built for
    with pytest.raises(cdpr.RobotFileError, match="planar2 robot with 16 cables is not supported") as info:
        cdpr.Robot.from_dict(bad)
    assert info.value.status == "unsupported-shape"
    with pytest.raises(ValueError, match="does not fit 64 bits"):
        cdpr.Robot.from_dict(dict(good, limits={"t_min": 1.0, "t_max": 2**70}))

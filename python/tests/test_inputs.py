"""Bad inputs raise clear exceptions before anything is computed, and
never crash the interpreter: wrong shapes (ValueError), wrong dtypes
(TypeError), NaN (the core's NonFiniteError for one pose, the row's
`nonfinite` in a batch), unknown methods; non-contiguous arrays are
accepted (read through their strides) with the same answers."""

from __future__ import annotations

import numpy as np
import pytest

import cdpr

POSE = [0.0, 0.0, 1.5, 0.0, 0.0, 0.0]


@pytest.fixture
def s8(robots):
    return robots["suspended-8"]


@pytest.mark.parametrize(
    "poses,match",
    [
        (np.zeros(5), r"poses: expected shape \(6,\) or \(k, 6\) \(x, y, z, rx, ry, rz for a spatial6 robot\), got shape \(5,\)"),
        (np.zeros((4, 3)), r"got shape \(4, 3\)"),
        (np.zeros((2, 3, 6)), r"got shape \(2, 3, 6\)"),
        (np.float64(1.0), r"got shape \(\)"),
        ([[0, 0, 1.5], [0, 0]], r"poses: not an array of numbers"),
    ],
)
def test_wrong_pose_shapes(s8, poses, match):
    with pytest.raises(ValueError, match=match):
        s8.solve(poses)


@pytest.mark.parametrize(
    "value,dtype",
    [
        (np.zeros(6, dtype=complex), "complex128"),
        (np.zeros(6, dtype=bool), "bool"),
        (np.array(["0"] * 6), "<U1"),
        (np.array([None] * 6), "object"),
        ("abcdef", "<U6"),
        (None, "object"),
    ],
)
def test_wrong_dtypes(s8, value, dtype):
    with pytest.raises(TypeError, match=f"poses: expected real numbers .* of dtype {dtype}"):
        s8.solve(value)


def test_other_arguments_are_checked(s8):
    with pytest.raises(ValueError, match=r"wrenches: expected shape \(6,\) or \(2, 6\)"):
        s8.solve(np.zeros((2, 6)), wrenches=np.zeros((3, 6)))
    with pytest.raises(ValueError, match=r"velocities: expected shape \(6,\) \("):
        s8.solve(POSE, velocities=np.zeros((1, 6)))
    with pytest.raises(TypeError, match="accelerations"):
        s8.solve(POSE, accelerations=np.zeros(6, dtype=complex))
    with pytest.raises(ValueError, match="method: unknown method `barycentre` \\(expected one of barycenter, "):
        s8.solve(POSE, method="barycentre")
    with pytest.raises(ValueError, match=r"lengths: expected shape \(8,\)"):
        s8.forward(np.ones(6))
    with pytest.raises(ValueError, match=r"guess: expected shape \(6,\)"):
        s8.forward(np.ones(8), guess=np.zeros(3))
    with pytest.raises(ValueError, match=r"tensions: expected shape \(8,\) or \(k, 8\)"):
        s8.motor_torques(np.ones((2, 7)))
    with pytest.raises(ValueError, match=r"pose: expected shape \(6,\)"):
        s8.wrench_matrix(np.zeros((1, 6)))
    with pytest.raises(ValueError, match="step: -1"):
        s8.workspace(-1.0)
    with pytest.raises(ValueError, match="step: NaN"):
        s8.workspace(float("nan"))
    with pytest.raises(ValueError, match="more than 50000000"):
        s8.workspace(1e-4)
    # Numbers in messages in a few digits (1e-9 was 0.000000001, a pose's
    # 1e300 301 digits).
    with pytest.raises(ValueError, match=r"^step: 1e-9: 4\.2e28 cells is more than 50000000"):
        s8.workspace(1e-9)
    with pytest.raises(cdpr.NonFiniteError, match=r"at pose \[1e300, 0, 1\.5, 0, 0, 0\]") as info:
        s8.solve([1e300, 0, 1.5, 0, 0, 0])
    assert len(str(info.value)) < 200
    with pytest.raises(ValueError, match=r"bounds: expected shape \(3, 2\)"):
        s8.workspace(0.5, bounds=[[0, 1], [0, 1]])
    with pytest.raises(ValueError, match="bounds: y from 1 to 0"):
        s8.workspace(0.5, bounds=[[0, 1], [1, 0], [0, 1]])
    with pytest.raises(ValueError, match="threads: 0"):
        s8.workspace(0.5, threads=0)
    with pytest.raises(ValueError, match=r"orientation: expected shape \(3,\)"):
        s8.workspace(0.5, orientation=[0.0])
    with pytest.raises(TypeError):
        s8.workspace("0.5")


def test_nan_one_pose_raises_a_batch_reports(s8):
    with pytest.raises(cdpr.NonFiniteError, match="nonfinite"):
        s8.solve([0, 0, np.nan, 0, 0, 0])
    with pytest.raises(cdpr.NonFiniteError):
        s8.solve(POSE, wrenches=[np.inf, 0, 0, 0, 0, 0])
    with pytest.raises(cdpr.NonFiniteError):
        s8.wrench_matrix([0, 0, np.nan, 0, 0, 0])
    with pytest.raises(cdpr.NonFiniteError):
        s8.cable_lengths([0, 0, np.inf, 0, 0, 0])
    poses = np.array([POSE, [0, 0, np.nan, 0, 0, 0], POSE])
    t, status = s8.solve(poses, velocities=np.array([np.zeros(6), np.zeros(6), [np.nan] * 6]))
    assert status.tolist() == ["ok", "nonfinite", "nonfinite"]


def test_non_contiguous_and_other_dtypes_give_the_same_answers(s8):
    rng = np.random.default_rng(0)
    poses = np.zeros((50, 6))
    poses[:, :3] = [0, 0, 1.5] + rng.uniform(-0.3, 0.3, (50, 3))
    want_t, want_s = s8.solve(poses)
    wide = np.zeros((100, 12))
    wide[::2, ::2] = poses
    view = wide[::2, ::2]
    assert not view.flags.c_contiguous
    for variant in [view, np.asfortranarray(poses), poses[::-1][::-1], poses.tolist()]:
        t, s = s8.solve(variant)
        np.testing.assert_array_equal(t, want_t)
        assert s.tolist() == want_s.tolist()
    # Integer and float32 arrays are converted to float64 (values as given).
    np.testing.assert_array_equal(s8.solve(np.array([0, 0, 1, 0, 0, 0])), s8.solve([0.0, 0.0, 1.0, 0.0, 0.0, 0.0]))
    p32 = poses.astype(np.float32)
    np.testing.assert_array_equal(s8.solve(p32)[0], s8.solve(p32.astype(np.float64))[0])


def test_empty_batch(s8):
    t, status = s8.solve(np.zeros((0, 6)))
    assert t.shape == (0, 8) and status.shape == (0,)


def test_outputs_are_fresh_float64_arrays(s8):
    t, status = s8.solve(np.array([POSE, POSE]))
    assert t.dtype == np.float64 and t.flags.c_contiguous and t.flags.writeable
    assert status.dtype.kind == "U"
    a = s8.anchors
    a[0, 0] = 99.0
    assert s8.anchors[0, 0] != 99.0


def test_robot_file_errors(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "x"\nkind = "spatial7"\n[limits]\nt_min = 1.0\nt_max = 2.0\n[platform]\nmass = 1.0\ngravity = [0.0, 0.0, -9.81]\n[[cable]]\nanchor = [0.0, 0.0, 1.0]\nattach = [0.0, 0.0, 0.0]\n')
    with pytest.raises(cdpr.RobotFileError, match=r"bad.toml, line 2, column 8: unknown kind `spatial7`"):
        cdpr.Robot.from_toml(bad)
    with pytest.raises(cdpr.RobotFileError, match="No such file"):
        cdpr.Robot.from_toml(tmp_path / "missing.toml")
    with pytest.raises(TypeError):
        cdpr.Robot.from_toml(3)

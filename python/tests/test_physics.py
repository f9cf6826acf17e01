"""The package's answers against independent numpy references
(`reference.py`, written from the conventions and the papers): `W t = f`
and the limits on random poses for every method, the wrench matrix, the
lengths, the static and dynamic wrench, the closed form (Pott et al.
2009's pseudo-inverse formula), the barycenter (the polygon's centroid by
brute force), motor torques, forward kinematics, and the GIL released."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

import reference as ref
from conftest import ROBOT_FILES

ALL = sorted(ROBOT_FILES)


def limits_hold(robot, t, tol):
    return np.all(t >= robot.t_min - tol) and np.all(t <= robot.t_max + tol)


@pytest.mark.parametrize("stem", ALL)
def test_every_method_balances_the_wrench_within_the_limits(robots, stem):
    robot = robots[stem]
    rng = np.random.default_rng(2016)
    poses = ref.random_poses(robot, 400, rng)
    extra = rng.normal(0.0, 0.1 * robot.mass, (400, robot.dof))
    w = ref.wrench_matrix(robot, poses)
    f = ref.static_wrench(robot, poses, extra)
    scale = robot.t_max.max()
    for method in robot.methods:
        t, status = robot.solve(poses, method=method, wrenches=extra)
        ok = status == "ok"
        assert ok.sum() >= 100, (method, np.unique(status, return_counts=True))
        assert np.all(np.isnan(t[~ok]))
        assert np.all(np.isfinite(t[ok]))
        residual = np.einsum("knm,km->kn", w[ok], t[ok]) - f[ok]
        assert np.abs(residual).max() < 1e-9 * scale, method
        assert limits_hold(robot, t[ok], 1e-9 * scale), method


@pytest.mark.parametrize("stem", ALL)
def test_kinematics_match_numpy(robots, stem):
    robot = robots[stem]
    poses = ref.random_poses(robot, 50, np.random.default_rng(7))
    w = ref.wrench_matrix(robot, poses)
    lengths = ref.cable_lengths(robot, poses)
    f = ref.static_wrench(robot, poses)
    for p, w_ref, l_ref, f_ref in zip(poses, w, lengths, f):
        np.testing.assert_allclose(robot.wrench_matrix(p), w_ref, atol=1e-12)
        np.testing.assert_allclose(robot.cable_lengths(p), l_ref, rtol=1e-13)
        np.testing.assert_allclose(robot.required_wrench(p), f_ref, atol=1e-9 * robot.mass)


def test_dynamic_wrench_matches_numpy(robots):
    """The d'Alembert wrench along a smooth pose path: the reference takes
    omega from the Euler rates and alpha by central differences of omega."""
    robot = robots["suspended-8"]
    t = np.linspace(0.1, 1.9, 19)
    h = 1e-5

    def path(s):
        s = np.asarray(s)[:, None]
        return np.hstack([0.3 * np.sin(s), 0.2 * np.cos(2 * s), 1.5 + 0.1 * s**2, 0.2 * np.sin(s), -0.1 * s, 0.3 * np.cos(s)])

    def rates(s):
        s = np.asarray(s)[:, None]
        return np.hstack([0.3 * np.cos(s), -0.4 * np.sin(2 * s), 0.2 * s, 0.2 * np.cos(s), -0.1 + 0 * s, -0.3 * np.sin(s)])

    def accel(s):
        s = np.asarray(s)[:, None]
        return np.hstack([-0.3 * np.sin(s), -0.8 * np.cos(2 * s), 0.2 + 0 * s, -0.2 * np.sin(s), 0 * s, -0.3 * np.cos(s)])

    q, dq, ddq = path(t), rates(t), accel(t)
    omega = ref.angular_velocity(q, dq)
    alpha = (ref.angular_velocity(path(t + h), rates(t + h)) - ref.angular_velocity(path(t - h), rates(t - h))) / (2 * h)
    f_ref = ref.dynamic_wrench(robot, q, omega, alpha, ddq[:, :3])
    for k in range(len(t)):
        f = robot.required_wrench(q[k], velocity=dq[k], acceleration=ddq[k])
        np.testing.assert_allclose(f, f_ref[k], atol=1e-6)
    # The batch uses the same wrench: W t = f_ref.
    tensions, status = robot.solve(q, velocities=dq, accelerations=ddq)
    assert np.all(status == "ok")
    w = ref.wrench_matrix(robot, q)
    np.testing.assert_allclose(np.einsum("knm,km->kn", w, tensions), f_ref, atol=1e-6)


@pytest.mark.parametrize("stem", ALL)
def test_closed_form_is_the_pseudo_inverse_formula(robots, stem):
    robot = robots[stem]
    poses = ref.random_poses(robot, 500, np.random.default_rng(11), spread=0.6)
    w = ref.wrench_matrix(robot, poses)
    f = ref.static_wrench(robot, poses)
    t_ref, inside = ref.closed_form(w, f, robot.t_min, robot.t_max)
    t, status = robot.solve(poses, method="closed-form")
    ok = status == "ok"
    assert ok.sum() > 0
    np.testing.assert_allclose(t[ok], t_ref[ok], rtol=1e-9, atol=1e-9 * robot.t_max.max())
    # Where the formula leaves the limits, the core says method-failed (or
    # infeasible, with its certificate); never ok.
    assert set(status[~inside].tolist()) <= {"method-failed", "infeasible"}
    # Borderline rows (within 1e-9 of a limit) may go either way.
    margin = np.minimum(t_ref - robot.t_min, robot.t_max - t_ref).min(axis=1)
    clear = np.abs(margin) > 1e-6 * robot.t_max.max()
    assert np.all(ok[clear] == inside[clear])


@pytest.mark.parametrize("stem", [s for s in ALL if s != "spatial6-10"])
def test_barycenter_is_the_polygon_centroid(robots, stem):
    robot = robots[stem]
    poses = ref.random_poses(robot, 200, np.random.default_rng(5), spread=0.6)
    w = ref.wrench_matrix(robot, poses)
    f = ref.static_wrench(robot, poses)
    t, status = robot.solve(poses, method="barycenter")
    compared = 0
    for k in range(len(poses)):
        t_ref = ref.barycenter(w[k], f[k], robot.t_min, robot.t_max)
        if status[k] == "ok":
            assert t_ref is not None
            np.testing.assert_allclose(t[k], t_ref, rtol=1e-7, atol=1e-7 * robot.t_max.max())
            compared += 1
        elif status[k] == "infeasible":
            assert t_ref is None
    assert compared >= 50


def test_motor_torques(robots):
    robot = robots["suspended-8"]
    winch = robot.winch
    tensions = np.array([[5.0, 10, 50, 100, 200, 300, 350, 20], [np.nan] * 8])
    tau = robot.motor_torques(tensions)
    raw = tensions * winch["drum_radius"] / (winch["gear_ratio"] * winch["efficiency"])
    np.testing.assert_allclose(tau[0], np.clip(raw[0], -winch["torque_max"], winch["torque_max"]), rtol=1e-15)
    assert np.all(np.isnan(tau[1]))
    assert tau.shape == tensions.shape
    with pytest.raises(ValueError, match="no \\[winch\\]"):
        robots["planar-point-4"].motor_torques(np.ones(4))


def test_motor_torques_say_which_the_limit_cut(robots):
    # suspended-8: tau = t 0.04 / (8 0.9) = t / 180 N m, limit 2.5 N m:
    # from 450 N a torque is cut (the board flags it; Python used to return
    # the cut torque with no word).
    robot = robots["suspended-8"]
    tensions = np.array([[5.0, 449.0, 451.0, 1e6, -451.0, -1.0, 350.0, np.nan], [450.0] * 8])
    tau, saturated = robot.motor_torques(tensions, return_saturated=True)
    w = robot.winch
    raw = tensions * w["drum_radius"] / (w["gear_ratio"] * w["efficiency"])  # the conventions' formula
    expected = np.abs(raw) > w["torque_max"]
    np.testing.assert_array_equal(saturated, expected)
    assert saturated.dtype == np.bool_ and saturated.shape == tensions.shape
    assert saturated[0].tolist() == [False, False, True, True, True, False, False, False]
    np.testing.assert_allclose(tau[0, :7], np.clip(raw[0, :7], -2.5, 2.5), rtol=1e-15)
    np.testing.assert_array_equal(tau, robot.motor_torques(tensions))
    one, cut = robot.motor_torques(np.full(8, 500.0), return_saturated=True)
    assert one.shape == (8,) and cut.all() and np.all(one == 2.5)


@pytest.mark.parametrize("stem", ALL)
def test_forward_kinematics_round_trip(robots, stem):
    robot = robots[stem]
    for p in ref.random_poses(robot, 10, np.random.default_rng(9)):
        np.testing.assert_allclose(robot.forward(robot.cable_lengths(p)), p, atol=1e-8)
        np.testing.assert_allclose(robot.forward(robot.cable_lengths(p), guess=p + 0.01), p, atol=1e-8)


def test_batch_runs_with_the_gil_released(robots):
    """Another Python thread keeps running while a large batch is solved."""
    robot = robots["suspended-8"]
    poses = ref.random_poses(robot, 100_000, np.random.default_rng(1))
    done = threading.Event()
    ticks = 0

    def solve():
        robot.solve(poses)
        done.set()

    worker = threading.Thread(target=solve)
    start = time.perf_counter()
    worker.start()
    time.sleep(0.01)  # let the worker enter the solve
    while not done.is_set():
        ticks += 1
    worker.join()
    elapsed = time.perf_counter() - start
    # Holding the GIL, the solve would stop this loop for its whole length.
    assert ticks > 1000, (ticks, elapsed)

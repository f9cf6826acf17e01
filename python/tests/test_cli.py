"""The package against the `cdpr` CLI built in the same run: the same
tensions (bit for bit) and statuses on every shipped robot and pose table,
for every method that serves the robot, and the same workspace volume and
forward kinematics."""

from __future__ import annotations

import csv
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest

import cdpr
from conftest import ROBOT_FILES, ROBOTS
from reference import random_poses

WRENCH_COLUMNS = {
    "spatial6": ["fx", "fy", "fz", "mx", "my", "mz"],
    "planar3": ["fx", "fy", "mz"],
    "planar2": ["fx", "fy"],
}


def read_table(path: Path, robot: cdpr.Robot):
    """Pose table (conventions): poses `(k, n)` and the extra wrenches or None."""
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    poses = np.array([[float(r[c]) for c in robot.pose_names] for r in rows])
    cols = WRENCH_COLUMNS[robot.kind]
    extra = None
    if rows and cols[0] in rows[0]:
        extra = np.array([[float(r[c]) for c in cols] for r in rows])
    return poses, extra


def run_solve(cli: str, robot_path: Path, method: str, poses_path: Path, out: Path, m: int):
    subprocess.run(
        [cli, "solve", "--robot", str(robot_path), "--method", method, "--poses", str(poses_path), "--out", str(out)],
        check=True,
        capture_output=True,
        text=True,
    )
    with open(out, newline="") as fh:
        rows = list(csv.DictReader(fh))
    tensions = np.array([[float(r[f"t{i + 1}"]) if r["status"] == "ok" else np.nan for i in range(m)] for r in rows])
    return tensions.reshape(len(rows), m), np.array([r["status"] for r in rows])


def tables():
    """(robot stem, table) for every shipped pose or waypoint table."""
    out = []
    for table in sorted(ROBOTS.glob("*.csv")):
        stem = re.sub(r"-(poses|waypoints|stream)$", "", table.stem)
        if stem in ROBOT_FILES:
            out.append((stem, table))
    return out


@pytest.mark.parametrize("stem,table", tables(), ids=lambda v: v.name if isinstance(v, Path) else v)
def test_shipped_tables_match_the_cli(cli, robots, tmp_path, stem, table):
    robot = robots[stem]
    poses, extra = read_table(table, robot)
    for method in robot.methods:
        want_t, want_s = run_solve(cli, ROBOT_FILES[stem], method, table, tmp_path / "t.csv", robot.cables)
        got_t, got_s = robot.solve(poses, method=method, wrenches=extra)
        assert got_s.tolist() == want_s.tolist(), method
        np.testing.assert_array_equal(got_t, want_t, err_msg=method)


@pytest.mark.parametrize("stem", sorted(ROBOT_FILES))
def test_random_tables_match_the_cli(cli, robots, tmp_path, stem):
    """300 random poses (some outside the workspace, so the warm start is
    carried across failed rows too) with random extra wrenches."""
    robot = robots[stem]
    rng = np.random.default_rng(16)
    poses = random_poses(robot, 300, rng, spread=0.9)
    extra = rng.normal(0.0, 0.2 * robot.mass, (300, robot.dof))
    path = tmp_path / "poses.csv"
    with open(path, "w") as fh:
        fh.write(",".join(robot.pose_names + WRENCH_COLUMNS[robot.kind]) + "\n")
        for p, e in zip(poses, extra):
            fh.write(",".join(repr(float(v)) for v in [*p, *e]) + "\n")
    statuses = set()
    for method in robot.methods:
        want_t, want_s = run_solve(cli, ROBOT_FILES[stem], method, path, tmp_path / "t.csv", robot.cables)
        got_t, got_s = robot.solve(poses, method=method, wrenches=extra)
        assert got_s.tolist() == want_s.tolist(), method
        np.testing.assert_array_equal(got_t, want_t, err_msg=method)
        statuses |= set(got_s.tolist())
    assert "ok" in statuses


@pytest.mark.parametrize("stem", ["suspended-8", "planar-point-4", "planar3-5"])
def test_workspace_matches_the_cli(cli, robots, tmp_path, stem):
    robot = robots[stem]
    step = 0.25 if robot.kind == "spatial6" else 0.1
    out = tmp_path / "ws"
    subprocess.run(
        [cli, "workspace", "--robot", str(ROBOT_FILES[stem]), "--step", str(step), "--threads", "2", "--out", str(out)],
        check=True,
        capture_output=True,
    )
    summary = (out / "summary.txt").read_text()
    cells = re.search(r"cells: (\d+); feasible (\d+)", summary)
    measure = float(re.search(r"(?:volume|area): ([0-9.]+)", summary).group(1))
    feasible, volume = robot.workspace(step, threads=2)
    assert feasible.size == int(cells.group(1))
    assert int(feasible.sum()) == int(cells.group(2))
    assert volume == pytest.approx(measure, abs=1e-6)
    axes = robot.workspace_axes(step)
    assert feasible.shape == tuple(len(a) for a in reversed(axes))


def test_forward_matches_the_cli(cli, robots, tmp_path):
    robot = robots["suspended-8"]
    poses = random_poses(robot, 20, np.random.default_rng(3))
    lengths = np.array([robot.cable_lengths(p) for p in poses])
    path = tmp_path / "lengths.csv"
    with open(path, "w") as fh:
        fh.write(",".join(f"l{i + 1}" for i in range(robot.cables)) + "\n")
        for row in lengths:
            fh.write(",".join(repr(float(v)) for v in row) + "\n")
    subprocess.run(
        [cli, "forward", "--robot", str(ROBOT_FILES["suspended-8"]), "--lengths", str(path), "--out", str(tmp_path / "p.csv")],
        check=True,
        capture_output=True,
    )
    with open(tmp_path / "p.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    for row, l, p in zip(rows, lengths, poses):
        assert row["status"] == "ok"
        want = np.array([float(row[c]) for c in robot.pose_names])
        # The CLI warm-starts each row from the previous one; the package's
        # forward starts cold: both find the same pose to the solver's
        # tolerance.
        np.testing.assert_allclose(robot.forward(l), want, atol=1e-9)
        np.testing.assert_allclose(want, p, atol=1e-9)

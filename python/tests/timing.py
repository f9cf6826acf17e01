"""Per-pose cost of a batch: the package from Python, the `cdpr solve` CLI
(a CSV written, the process run, its CSV read back), and the numpy
reference (`reference.py`: the closed form batched with `numpy.linalg.pinv`,
the barycenter by brute force pose by pose), each computing W and f from
the poses too.

    python python/tests/timing.py --poses 10000 [--cli target/wheel/cdpr]

The test `test_timing.py` runs it on fewer poses and prints the table
(nothing is asserted about speed).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import reference as ref  # noqa: E402

import cdpr  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]


def best_of(fn, repeat: int) -> float:
    """The shortest of `repeat` runs, s."""
    best = float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def cli_seconds(cli: str, robot_path: Path, method: str, poses: np.ndarray, names: list[str]) -> tuple[float, float]:
    """(seconds for the whole table, seconds for a one-row table) of `cdpr solve`."""
    with tempfile.TemporaryDirectory() as tmp:
        times = []
        for rows in (poses, poses[:1]):
            path = Path(tmp) / f"poses-{len(rows)}.csv"
            with open(path, "w") as fh:
                fh.write(",".join(names) + "\n")
                fh.writelines(",".join(repr(float(v)) for v in p) + "\n" for p in rows)
            out = Path(tmp) / "out.csv"
            cmd = [cli, "solve", "--robot", str(robot_path), "--method", method, "--poses", str(path), "--out", str(out)]
            times.append(best_of(lambda: subprocess.run(cmd, check=True, capture_output=True), 3))
        return times[0], times[1]


def compare(k: int = 10_000, numpy_k: int | None = None, cli: str | None = None, robot_file: str = "suspended-8") -> list[str]:
    """The table's lines: microseconds per pose for each way and method."""
    robot_path = ROOT / "robots" / f"{robot_file}.toml"
    robot = cdpr.Robot.from_toml(robot_path)
    poses = ref.random_poses(robot, k, np.random.default_rng(10))
    numpy_k = min(k, numpy_k or k)
    sub = poses[:numpy_k]
    lines = [
        f"{robot.name}: {k} random poses (numpy barycenter on {numpy_k}); microseconds per pose, best of 3",
        f"{'method':<12} {'python':>9} {'cli':>9} {'cli-start':>9} {'numpy':>9}",
    ]
    for method in ("closed-form", "barycenter"):
        py = best_of(lambda: robot.solve(poses, method=method), 3) / k
        if cli:
            total, one = cli_seconds(cli, robot_path, method, poses, robot.pose_names)
            cli_pp, cli_net = total / k, (total - one) / max(k - 1, 1)
        else:
            cli_pp = cli_net = float("nan")

        def numpy_way():
            w = ref.wrench_matrix(robot, sub)
            f = ref.static_wrench(robot, sub)
            if method == "closed-form":
                ref.closed_form(w, f, robot.t_min, robot.t_max)
            else:
                for wk, fk in zip(w, f):
                    ref.barycenter(wk, fk, robot.t_min, robot.t_max)

        np_pp = best_of(numpy_way, 3 if method == "closed-form" else 1) / numpy_k
        lines.append(f"{method:<12} {py * 1e6:9.2f} {cli_pp * 1e6:9.2f} {cli_net * 1e6:9.2f} {np_pp * 1e6:9.2f}")
    lines.append("cli: `cdpr solve` whole run / its start-up (one-row table) taken off; python: robot.solve on the batch")
    return lines


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--poses", type=int, default=10_000)
    parser.add_argument("--numpy-poses", type=int, default=None)
    parser.add_argument("--cli", default=os.environ.get("CDPR_CLI"))
    parser.add_argument("--robot", default="suspended-8")
    args = parser.parse_args()
    print("\n".join(compare(args.poses, args.numpy_poses, args.cli, args.robot)))


if __name__ == "__main__":
    main()

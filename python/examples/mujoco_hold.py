"""suspended-8 in MuJoCo, held and moved by the barycenter tensions.

The model is built from the robot file through the package's accessors:
the platform a free body (the file's mass, centre of mass and inertia; a
payload the controller does not know can be added), eight spatial tendons
from the anchors (world sites) to the attachments (platform sites), each
driven by a motor actuator whose force is the cable's tension
(``gear = -1``: a positive control pulls the tendon shorter; ``ctrlrange``
is the file's limits).

At every simulation step (1 kHz, the firmware's rate) the controller
reads the simulated pose and its rates, adds a task-space PD to the
reference's acceleration,

    qdd_cmd = qdd_ref + Kp (q_ref - q) + Kd (qd_ref - qd),

and asks ``robot.solve`` for the barycenter tensions at the simulated pose
with that acceleration (the d'Alembert wrench: feed-forward plus the PD,
i.e. computed-torque control through the cables); it applies them as the
motors' controls. Should the PD make the wrench infeasible, the PD is
halved until it is not (as the firmware's feedback backs off), and the
backoffs are counted.

The reference holds the pose ``[0, 0, 1.5, 0, 0, 0]``, then follows a loop
(a figure of eight in x-y, rising 0.2 m, with roll and yaw, along the
conventions' 7th-degree time law), then holds again. The figure of the
pose error and the tensions is written with matplotlib, headless.

    python python/examples/mujoco_hold.py --out mujoco_hold.png
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import cdpr

ROOT = Path(__file__).resolve().parents[2]
DEFAULT_ROBOT = ROOT / "robots" / "suspended-8.toml"
HOME = np.array([0.0, 0.0, 1.5, 0.0, 0.0, 0.0])


# --- the reference -----------------------------------------------------------


def time_law(u: float) -> tuple[float, float, float]:
    """``s(u) = 35u^4 - 84u^5 + 70u^6 - 20u^7`` and its first two derivatives."""
    u = min(max(u, 0.0), 1.0)
    s = 35 * u**4 - 84 * u**5 + 70 * u**6 - 20 * u**7
    ds = 140 * u**3 - 420 * u**4 + 420 * u**5 - 140 * u**6
    dds = 420 * u**2 - 1680 * u**3 + 2100 * u**4 - 840 * u**5
    return s, ds, dds


def loop_shape(phi: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The loop's offset from HOME at angle ``phi`` and its derivatives in phi."""
    r = 0.4
    q = np.array([r * np.sin(phi), 0.5 * r * np.sin(2 * phi), 0.1 * (1 - np.cos(phi)), 0.05 * np.sin(2 * phi), 0.0, 0.15 * np.sin(phi)])
    dq = np.array([r * np.cos(phi), r * np.cos(2 * phi), 0.1 * np.sin(phi), 0.1 * np.cos(2 * phi), 0.0, 0.15 * np.cos(phi)])
    ddq = np.array([-r * np.sin(phi), -2 * r * np.sin(2 * phi), 0.1 * np.cos(phi), -0.2 * np.sin(2 * phi), 0.0, -0.15 * np.sin(phi)])
    return q, dq, ddq


def reference(t: float, hold: float, loop: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pose, rates and accelerations of the reference at time ``t``."""
    if t <= hold or t >= hold + loop:
        return HOME.copy(), np.zeros(6), np.zeros(6)
    s, ds, dds = time_law((t - hold) / loop)
    phi = 2 * np.pi * s
    dphi = 2 * np.pi * ds / loop
    ddphi = 2 * np.pi * dds / loop**2
    q, dq, ddq = loop_shape(phi)
    return HOME + q, dq * dphi, ddq * dphi**2 + dq * ddphi


# --- poses and MuJoCo's free joint ------------------------------------------


def rotation(angles: np.ndarray) -> np.ndarray:
    """``R = Rx(a) Ry(b) Rz(c)`` (conventions: XYZ Euler angles)."""
    a, b, c = angles
    rx = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    ry = np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])
    rz = np.array([[np.cos(c), -np.sin(c), 0], [np.sin(c), np.cos(c), 0], [0, 0, 1]])
    return rx @ ry @ rz


def angles_of(rot: np.ndarray) -> np.ndarray:
    """The XYZ Euler angles of ``R`` (``|ry| < pi/2``)."""
    return np.array([np.arctan2(-rot[1, 2], rot[2, 2]), np.arcsin(np.clip(rot[0, 2], -1, 1)), np.arctan2(-rot[0, 1], rot[0, 0])])


def euler_rates(angles: np.ndarray, omega_world: np.ndarray) -> np.ndarray:
    """The angle rates whose angular velocity is ``omega`` (base frame):
    ``omega = a' e_x + b' Rx(a) e_y + c' Rx(a) Ry(b) e_z``."""
    a, b, _ = angles
    e = np.array([[1, 0, np.sin(b)], [0, np.cos(a), -np.sin(a) * np.cos(b)], [0, np.sin(a), np.cos(a) * np.cos(b)]])
    return np.linalg.solve(e, omega_world)


def quaternion(rot: np.ndarray) -> np.ndarray:
    import mujoco

    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, rot.flatten())
    return q


def sim_pose(data) -> tuple[np.ndarray, np.ndarray]:
    """The platform's pose and pose rates from the free joint's qpos/qvel
    (qvel: world-frame linear velocity, body-frame angular velocity)."""
    import mujoco

    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, data.qpos[3:7])
    rot = rot.reshape(3, 3)
    angles = angles_of(rot)
    pose = np.concatenate([data.qpos[:3], angles])
    rates = np.concatenate([data.qvel[:3], euler_rates(angles, rot @ data.qvel[3:6])])
    return pose, rates


# --- the model -------------------------------------------------------------


def mjcf(robot: cdpr.Robot, start: np.ndarray, dt: float, payload: float) -> str:
    """The MJCF text of the robot, the platform at ``start``."""
    if robot.kind != "spatial6":
        raise ValueError(f"{robot.name} is {robot.kind}: the MuJoCo example is for spatial6 robots")
    inertia = robot.inertia
    if np.linalg.eigvalsh(inertia).min() <= 0:
        raise ValueError(f"{robot.name}: the platform's inertia must be positive definite for a MuJoCo body")
    fmt = lambda v: " ".join(f"{x:.12g}" for x in v)  # noqa: E731
    mass = robot.mass + payload
    full = [inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[0, 1], inertia[0, 2], inertia[1, 2]]
    full = np.array(full) * mass / robot.mass  # the payload scales the body
    sites = "\n".join(f'    <site name="a{i + 1}" pos="{fmt(a)}" size="0.03" rgba="0.8 0.2 0.2 1"/>' for i, a in enumerate(robot.anchors))
    attach = "\n".join(f'      <site name="b{i + 1}" pos="{fmt(b)}" size="0.015"/>' for i, b in enumerate(robot.attachments))
    half = np.abs(robot.attachments).max(axis=0) + 0.01
    tendons = "\n".join(
        f'    <spatial name="c{i + 1}" width="0.004"><site site="a{i + 1}"/><site site="b{i + 1}"/></spatial>' for i in range(robot.cables)
    )
    motors = "\n".join(
        f'    <motor name="m{i + 1}" tendon="c{i + 1}" gear="-1" ctrllimited="true" ctrlrange="{lo:.12g} {hi:.12g}"/>'
        for i, (lo, hi) in enumerate(robot.limits)
    )
    return f"""<mujoco model="{robot.name}">
  <option timestep="{dt}" gravity="{fmt(robot.gravity)}" integrator="RK4"/>
  <worldbody>
{sites}
    <body name="platform" pos="{fmt(start[:3])}" quat="{fmt(quaternion(rotation(start[3:])))}">
      <freejoint name="platform"/>
      <inertial pos="{fmt(robot.com)}" mass="{mass:.12g}" fullinertia="{fmt(full)}"/>
      <geom type="box" size="{fmt(half)}" contype="0" conaffinity="0" rgba="0.3 0.5 0.8 0.6"/>
{attach}
    </body>
  </worldbody>
  <tendon>
{tendons}
  </tendon>
  <actuator>
{motors}
  </actuator>
</mujoco>
"""


# --- the run ----------------------------------------------------------------


@dataclass
class Run:
    """What a run recorded, one row per step."""

    time: np.ndarray  #: s
    reference: np.ndarray  #: (k, 6) reference poses
    pose: np.ndarray  #: (k, 6) simulated poses
    tensions: np.ndarray  #: (k, m) tensions computed, N
    applied: np.ndarray  #: (k, m) tensions MuJoCo applied (actuator_force), N
    backoffs: int  #: steps where the PD was scaled down
    t_min: np.ndarray
    t_max: np.ndarray
    seconds: float  #: wall time of the loop
    name: str  #: the robot's name
    payload: float  #: kg unknown to the controller
    kp: float
    kd: float

    @property
    def position_error(self) -> np.ndarray:
        """|p - p_ref| per step, m."""
        return np.linalg.norm(self.pose[:, :3] - self.reference[:, :3], axis=1)

    @property
    def angle_error(self) -> np.ndarray:
        """max |angle - angle_ref| per step, rad."""
        return np.abs(self.pose[:, 3:] - self.reference[:, 3:]).max(axis=1)


def run(robot_file: Path = DEFAULT_ROBOT, hold: float = 1.0, loop: float = 8.0, rest: float = 1.0,
        payload: float = 0.3, dt: float = 1e-3, kp: float = 400.0, kd: float = 40.0) -> Run:
    """Simulates ``hold + loop + rest`` seconds; see the module's text."""
    import mujoco

    robot = cdpr.Robot.from_toml(robot_file)
    model = mujoco.MjModel.from_xml_string(mjcf(robot, HOME, dt, payload))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    steps = int(round((hold + loop + rest) / dt))
    rec_t = np.zeros(steps)
    rec_ref, rec_pose = np.zeros((steps, 6)), np.zeros((steps, 6))
    rec_ten, rec_app = np.zeros((steps, robot.cables)), np.zeros((steps, robot.cables))
    backoffs = 0
    last = None
    start = time.perf_counter()
    for k in range(steps):
        t = data.time
        q_ref, dq_ref, ddq_ref = reference(t, hold, loop)
        q, dq = sim_pose(data)
        feedback = kp * (q_ref - q) + kd * (dq_ref - dq)
        tensions = None
        for scale in (1.0, 0.5, 0.25, 0.125, 0.0):
            try:
                tensions = robot.solve(q, method="barycenter", velocities=dq, accelerations=ddq_ref + scale * feedback)
                break
            except cdpr.CdprError:
                backoffs += 1
        if tensions is None:
            if last is None:
                raise RuntimeError(f"t = {t:.3f} s: no tensions hold the platform at {q}")
            tensions = last
        last = tensions
        data.ctrl[:] = tensions
        mujoco.mj_step(model, data)
        rec_t[k], rec_ref[k], rec_pose[k] = t, q_ref, q
        rec_ten[k], rec_app[k] = tensions, data.actuator_force.copy()
    seconds = time.perf_counter() - start
    return Run(rec_t, rec_ref, rec_pose, rec_ten, rec_app, backoffs, robot.t_min, robot.t_max, seconds, robot.name, payload, kp, kd)


def plot(result: Run, path: Path) -> None:
    """The pose error and the tensions against time, as a PNG (headless)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = result.time
    fig, axes = plt.subplots(3, 1, figsize=(10, 9), sharex=True)
    err = (result.pose - result.reference) * 1e3
    for i, name in enumerate(["x", "y", "z"]):
        axes[0].plot(t, err[:, i], label=name)
    axes[0].set_ylabel("position error [mm]")
    axes[0].legend(loc="upper right", ncol=3)
    for i, name in enumerate(["rx", "ry", "rz"]):
        axes[1].plot(t, err[:, 3 + i], label=name)
    axes[1].set_ylabel("angle error [mrad]")
    axes[1].legend(loc="upper right", ncol=3)
    for i in range(result.tensions.shape[1]):
        axes[2].plot(t, result.applied[:, i], lw=1, label=f"t{i + 1}")
    axes[2].axhline(result.t_min.min(), color="k", ls="--", lw=0.8)
    axes[2].axhline(result.t_max.max(), color="k", ls="--", lw=0.8)
    lo, hi = result.applied.min(), result.applied.max()
    axes[2].set_ylim(min(0.0, lo - 5), hi + 0.25 * (hi - lo) + 5)
    axes[2].text(t[0], result.t_min.min(), " t_min", va="bottom", fontsize=8)
    if result.t_max.max() > axes[2].get_ylim()[1]:
        axes[2].text(t[0], axes[2].get_ylim()[1], f" t_max = {result.t_max.max():g} N, off the scale", va="top", fontsize=8)
    axes[2].set_ylabel("tension [N]")
    axes[2].set_xlabel("time [s]")
    axes[2].legend(loc="upper right", ncol=8, fontsize=8)
    fig.suptitle(
        f"{result.name} in MuJoCo: barycenter tensions from feed-forward + task-space PD (Kp {result.kp:g}, Kd {result.kd:g})\n"
        f"hold, figure-of-eight loop, hold; the simulated platform carries {result.payload:g} kg the controller does not know"
    )
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def summary(result: Run) -> str:
    return (
        f"{len(result.time)} steps of {result.time[1] - result.time[0]:.3g} s in {result.seconds:.2f} s "
        f"({result.seconds / len(result.time) * 1e6:.0f} us per step, solve and mj_step)\n"
        f"max position error {result.position_error.max() * 1e3:.3f} mm, "
        f"max angle error {result.angle_error.max() * 1e3:.3f} mrad\n"
        f"tensions {result.applied.min():.2f} .. {result.applied.max():.2f} N "
        f"(limits {result.t_min.min():g} .. {result.t_max.max():g} N), PD backoffs {result.backoffs}"
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--robot", type=Path, default=DEFAULT_ROBOT, help="a spatial6 robot file")
    parser.add_argument("--hold", type=float, default=1.0, help="s at the pose before the loop")
    parser.add_argument("--loop", type=float, default=8.0, help="s for the loop")
    parser.add_argument("--rest", type=float, default=1.0, help="s at the pose after the loop")
    parser.add_argument("--payload", type=float, default=0.3, help="kg the simulated platform has that the robot file does not")
    parser.add_argument("--out", type=Path, default=Path("mujoco_hold.png"), help="the figure (PNG)")
    args = parser.parse_args()
    result = run(args.robot, args.hold, args.loop, args.rest, args.payload)
    plot(result, args.out)
    print(summary(result))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()

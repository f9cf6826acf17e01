"""Independent numpy references for the tests and the timing comparison.

Written from ``docs/conventions.md`` and the papers, not from the Rust code:

* ``rotation``, ``wrench_matrix``, ``cable_lengths``, ``static_wrench``,
  ``dynamic_wrench``: the conventions' kinematics, vectorised over a batch.
* ``closed_form``: Pott et al. 2009, ``t = t_m + W^+ (f - W t_m)`` with
  ``t_m = (t_min + t_max) / 2``, batched with ``numpy.linalg.pinv``.
* ``barycenter``: the area centroid of the feasible polygon (redundancy 2),
  by brute force as Mikelsons et al. 2008 (every pairwise intersection of
  the limit lines in the null-space coordinates, the feasible ones ordered
  by angle, the shoelace centroid): no walk, no warm start.
"""

from __future__ import annotations

import numpy as np


def rotation(kind: str, poses: np.ndarray) -> np.ndarray:
    """``R`` for each pose of a batch ``(k, n)``: shape ``(k, 3, 3)``."""
    poses = np.atleast_2d(poses)
    k = poses.shape[0]
    if kind == "spatial6":
        a, b, c = poses[:, 3], poses[:, 4], poses[:, 5]
        one, zero = np.ones(k), np.zeros(k)
        rx = np.stack([one, zero, zero, zero, np.cos(a), -np.sin(a), zero, np.sin(a), np.cos(a)], -1)
        ry = np.stack([np.cos(b), zero, np.sin(b), zero, one, zero, -np.sin(b), zero, np.cos(b)], -1)
        rz = np.stack([np.cos(c), -np.sin(c), zero, np.sin(c), np.cos(c), zero, zero, zero, one], -1)
        return rx.reshape(k, 3, 3) @ ry.reshape(k, 3, 3) @ rz.reshape(k, 3, 3)
    if kind == "planar3":
        th = poses[:, 2]
        out = np.zeros((k, 3, 3))
        out[:, 0, 0], out[:, 0, 1] = np.cos(th), -np.sin(th)
        out[:, 1, 0], out[:, 1, 1] = np.sin(th), np.cos(th)
        out[:, 2, 2] = 1.0
        return out
    return np.broadcast_to(np.eye(3), (k, 3, 3)).copy()


def _cable_vectors(robot, poses: np.ndarray):
    """``l_i = a_i - p - R b_i`` and ``R b_i`` per pose: ``(k, m, 3)`` each."""
    poses = np.atleast_2d(poses)
    k = poses.shape[0]
    p = np.zeros((k, 3))
    p[:, :2] = poses[:, :2]
    if robot.kind == "spatial6":
        p[:, 2] = poses[:, 2]
    rot = rotation(robot.kind, poses)
    rb = np.einsum("kij,mj->kmi", rot, robot.attachments)
    anchors = np.broadcast_to(robot.anchors, (k, robot.cables, 3)).copy()
    if robot.kind != "spatial6":
        anchors[..., 2] = 0.0
        rb[..., 2] = 0.0
    if robot.kind == "planar2":
        rb[:] = 0.0
    return anchors - p[:, None, :] - rb, rb


def cable_lengths(robot, poses: np.ndarray) -> np.ndarray:
    """``|l_i|`` per pose: ``(k, m)``."""
    l, _ = _cable_vectors(robot, poses)
    return np.linalg.norm(l, axis=-1)


def wrench_matrix(robot, poses: np.ndarray) -> np.ndarray:
    """``W`` per pose: ``(k, n, m)`` (conventions, "the wrench matrix")."""
    l, rb = _cable_vectors(robot, poses)
    u = l / np.linalg.norm(l, axis=-1, keepdims=True)
    if robot.kind == "spatial6":
        return np.concatenate([u, np.cross(rb, u)], axis=-1).transpose(0, 2, 1)
    if robot.kind == "planar3":
        mz = rb[..., 0] * u[..., 1] - rb[..., 1] * u[..., 0]
        return np.stack([u[..., 0], u[..., 1], mz], axis=1)
    return np.stack([u[..., 0], u[..., 1]], axis=1)


def _wrench_rows(kind: str, force: np.ndarray, moment: np.ndarray) -> np.ndarray:
    if kind == "spatial6":
        return np.concatenate([force, moment], axis=-1)
    if kind == "planar3":
        return np.stack([force[:, 0], force[:, 1], moment[:, 2]], axis=-1)
    return force[:, :2]


def static_wrench(robot, poses: np.ndarray, extra: np.ndarray | None = None) -> np.ndarray:
    """``f = -w_e``: gravity ``m g`` at ``R c`` plus an extra wrench: ``(k, n)``."""
    poses = np.atleast_2d(poses)
    k = poses.shape[0]
    rc = rotation(robot.kind, poses) @ robot.com
    if robot.kind == "planar2":
        rc[:] = 0.0
    force = np.broadcast_to(robot.mass * robot.gravity, (k, 3))
    w_e = _wrench_rows(robot.kind, force, np.cross(rc, force))
    if extra is not None:
        w_e = w_e + extra
    return -w_e


def angular_velocity(poses: np.ndarray, rates: np.ndarray) -> np.ndarray:
    """``omega = a' e_x + b' Rx(a) e_y + c' Rx(a) Ry(b) e_z`` (spatial6): ``(k, 3)``."""
    a, b = poses[:, 3], poses[:, 4]
    e1 = np.stack([np.ones_like(a), 0 * a, 0 * a], -1)
    e2 = np.stack([0 * a, np.cos(a), np.sin(a)], -1)
    e3 = np.stack([np.sin(b), -np.sin(a) * np.cos(b), np.cos(a) * np.cos(b)], -1)
    return e1 * rates[:, 3:4] + e2 * rates[:, 4:5] + e3 * rates[:, 5:6]


def dynamic_wrench(robot, poses, omega, alpha, accel) -> np.ndarray:
    """``f = -w_e`` with the d'Alembert wrench (spatial6), from the angular
    velocity and acceleration (base frame) and the origin's acceleration."""
    rot = rotation("spatial6", poses)
    rc = rot @ robot.com
    a_c = accel + np.cross(alpha, rc) + np.cross(omega, np.cross(omega, rc))
    force = robot.mass * robot.gravity - robot.mass * a_c
    inertia_w = rot @ robot.inertia @ rot.transpose(0, 2, 1)
    iw_alpha = np.einsum("kij,kj->ki", inertia_w, alpha)
    iw_omega = np.einsum("kij,kj->ki", inertia_w, omega)
    moment = np.cross(rc, force) - (iw_alpha + np.cross(omega, iw_omega))
    return -np.concatenate([force, moment], axis=-1)


def closed_form(w: np.ndarray, f: np.ndarray, t_min: np.ndarray, t_max: np.ndarray):
    """Pott et al. 2009 for a batch: tensions ``(k, m)`` and whether each row
    is within the limits (else the method fails: ``method-failed``)."""
    t_m = 0.5 * (t_min + t_max)
    rhs = f - w @ t_m
    t = t_m + np.einsum("kmn,kn->km", np.linalg.pinv(w), rhs)
    scale = np.max(t_max)
    inside = np.all((t >= t_min - 1e-9 * scale) & (t <= t_max + 1e-9 * scale), axis=1)
    return t, inside


def barycenter(w: np.ndarray, f: np.ndarray, t_min: np.ndarray, t_max: np.ndarray):
    """The feasible polygon's area centroid for one pose (``m = n + 2``), or
    None when the polygon is empty (or has no area)."""
    n, m = w.shape
    t_p = np.linalg.lstsq(w, f, rcond=None)[0]
    null = np.linalg.svd(w)[2][n:].T  # (m, 2), W null = 0
    # t_min <= t_p + N lam <= t_max as a_j . lam <= b_j, 2m half-planes.
    a = np.concatenate([null, -null])
    b = np.concatenate([t_max - t_p, t_p - t_min])
    i, j = np.triu_indices(2 * m, 1)
    det = a[i, 0] * a[j, 1] - a[i, 1] * a[j, 0]
    ok = np.abs(det) > 1e-12
    i, j, det = i[ok], j[ok], det[ok]
    x = (b[i] * a[j, 1] - b[j] * a[i, 1]) / det
    y = (a[i, 0] * b[j] - a[j, 0] * b[i]) / det
    pts = np.stack([x, y], -1)
    tol = 1e-9 * (1.0 + np.max(np.abs(b)))
    pts = pts[np.all(pts @ a.T <= b + tol, axis=1)]
    if len(pts) < 3:
        return None
    centre = pts.mean(axis=0)
    order = np.argsort(np.arctan2(pts[:, 1] - centre[1], pts[:, 0] - centre[0]))
    p = pts[order]
    q = np.roll(p, -1, axis=0)
    cross = p[:, 0] * q[:, 1] - q[:, 0] * p[:, 1]
    area = cross.sum() / 2
    if abs(area) < 1e-14:
        return None
    cx = ((p[:, 0] + q[:, 0]) * cross).sum() / (6 * area)
    cy = ((p[:, 1] + q[:, 1]) * cross).sum() / (6 * area)
    return t_p + null @ np.array([cx, cy])


def random_poses(robot, k: int, rng: np.random.Generator, spread: float = 0.25) -> np.ndarray:
    """Poses around the centre of the anchors' box (half the anchors' height
    for a suspended robot), within ``spread`` times its half-size, angles
    ~ N(0, 0.1 rad)."""
    lo, hi = robot.anchors.min(0), robot.anchors.max(0)
    centre, half = (lo + hi) / 2, (hi - lo) / 2
    if robot.kind == "spatial6" and half[2] < 0.1 * half[:2].max():
        # Suspended: every anchor at about one height, the platform below.
        centre[2], half[2] = hi[2] / 2, hi[2] / 2
    poses = np.zeros((k, robot.dof))
    d = 3 if robot.kind == "spatial6" else 2
    poses[:, :d] = centre[:d] + rng.uniform(-spread, spread, (k, d)) * half[:d]
    if robot.kind == "spatial6":
        poses[:, 3:] = rng.normal(0.0, 0.1, (k, 3))
    elif robot.kind == "planar3":
        poses[:, 2] = rng.normal(0.0, 0.1, k)
    return poses

"""The MuJoCo example on a short horizon: the platform stays within a
stated distance of its reference, and every tension the simulator applied
is within the robot file's limits.

Bounds: the simulated platform carries 0.3 kg the controller does not know
(the example's default), which a PD without integral leaves as a steady
sag of about 0.3 * 9.81 / (6.64 kg * Kp 400) = 1.1 mm; the bound is 3 mm in
position and 1 mrad in every angle (measured: 1.18 mm, 0.08 mrad). Without
the PD the same platform falls far beyond it (checked too, so the bound
means something)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mujoco")
pytest.importorskip("matplotlib")

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "mujoco_hold.py"
POSITION_BOUND = 3e-3  # m
ANGLE_BOUND = 1e-3  # rad


@pytest.fixture(scope="module")
def example():
    spec = importlib.util.spec_from_file_location("mujoco_hold", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    sys.modules["mujoco_hold"] = module  # for its dataclass
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def result(example):
    # 0.5 s hold, the whole 8 s loop (its fastest part is in the middle), 0.5 s hold.
    return example.run(hold=0.5, loop=8.0, rest=0.5)


def test_the_platform_follows_its_reference(result):
    assert len(result.time) == 9000
    assert result.position_error.max() < POSITION_BOUND, result.position_error.max()
    assert result.angle_error.max() < ANGLE_BOUND, result.angle_error.max()
    # It moved: the loop's reference leaves the held pose by 0.4 m.
    assert np.abs(result.reference[:, 0]).max() > 0.3
    assert result.backoffs == 0


def test_every_applied_tension_is_within_the_limits(result):
    assert np.all(result.applied >= result.t_min) and np.all(result.applied <= result.t_max)
    # MuJoCo applied what the controller computed (its ctrlrange clipped nothing).
    np.testing.assert_allclose(result.applied, result.tensions, rtol=0, atol=1e-12)


def test_the_figure_is_written(example, result, tmp_path):
    path = tmp_path / "hold.png"
    example.plot(result, path)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    print(example.summary(result))


def test_without_the_pd_the_bound_is_broken(example):
    open_loop = example.run(hold=1.0, loop=0.0, rest=0.0, kp=0.0, kd=0.0)
    assert open_loop.position_error.max() > 10 * POSITION_BOUND

"""Real robot files (example-robot-data) under a spacecraft, against Pinocchio's own URDF parser.

A UR5, a Kinova arm, a Panda with its two prismatic fingers and a Baxter with both arms (and
its zero-inertia gripper links) are read by freefloat and, from the same file, by
``pinocchio.buildModelFromUrdf`` with a free-flyer root. Everything in ``compare`` agrees to a
relative 1e-10 (the issue asks 1e-8): mass, system CM, end-effector positions about the CM,
momenta, kinetic energy, H+, J*, J+ and a random point Jacobian, for the engine and for the
barycentric forms; five random states per robot.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import freefloat as ff
from freefloat.io.oracles import pinocchio_root_joint
from oracle.test_pinocchio_core import PinocchioSystem, compare
from robots import REAL_ROBOTS, spacecraft_urdf


@pytest.mark.parametrize("name", sorted(REAL_ROBOTS))
def test_real_robot_matches_pinocchio(name: str, tmp_path: Path) -> None:
    relative, tools = REAL_ROBOTS[name]
    path = spacecraft_urdf(relative, tmp_path)
    model = ff.load(path, end_effectors=tools)
    assert model.end_effector_rule == "named" and model.end_effector_names == tuple(tools or ())
    assert model.body_names[0] == "spacecraft"
    pm = pin.buildModelFromUrdf(str(path), pinocchio_root_joint())
    pm.gravity = pin.Motion.Zero()
    system = PinocchioSystem(model, pm, model.end_effector_names)
    rng = np.random.default_rng(sum(map(ord, name)))
    for _ in range(5):
        compare(model, system, rng)
    if name == "panda":
        assert model.joint_type.count("prismatic") == 2, "the Panda's fingers slide"
    if name == "baxter":
        assert model.n_joints >= 14 and len(tools or ()) == 2, "both arms"


def test_unnamed_end_effectors_keep_every_leaf(tmp_path: Path) -> None:
    """Without names, every leaf link is an end effector (today's rule), and the model says so."""
    path = spacecraft_urdf(REAL_ROBOTS["baxter"][0], tmp_path)
    model = ff.load(path)
    assert model.end_effector_rule == "leaves"
    assert model.n_end_effectors > 20  # cameras, sonar, visual frames...: why users name theirs

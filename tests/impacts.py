"""Random robot states and moving targets for the impact tests (tests/mechanics/test_impact.py, tests/oracle/test_pinocchio_impact.py)."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

import freefloat as ff
from trees import random_inertia


def random_state(model: ff.Model, rng: np.random.Generator, moving: bool = True) -> ff.State:
    """A configuration within the joint limits, a random attitude and CM, and (``moving``) random rates."""
    n = model.n_joints
    scale = 0.3 if moving else 0.0
    return ff.State(
        q=rng.uniform(np.maximum(model.joint_lower, -np.pi), np.minimum(model.joint_upper, np.pi)),
        qdot=rng.normal(scale=scale, size=n),
        omega=rng.normal(scale=scale, size=3),
        attitude=Rotation.random(random_state=rng),
        r_cm=rng.normal(scale=2.0, size=3),
        v_cm=rng.normal(scale=scale, size=3),
    )


def random_target(model: ff.Model, state: ff.State, e: int, rng: np.random.Generator, size: tuple[int, ...] = ()) -> ff.capture.Target:
    """A target held by end effector ``e`` (its CM within ~0.3 m of the end-effector point, and within 4 of the
    target's radii of gyration: the hand is on it, as ``ff.capture.impact`` asks), random mass, shape and motion."""
    s = state.resolve(model)
    tip = s.r_cm + s.rotation.apply(ff.end_effector_positions(model, s.q)[e])
    count = int(np.prod(size))
    mass = np.exp(rng.uniform(np.log(0.5), np.log(2000.0), size=count))
    inertia = np.array([random_inertia(rng, m) for m in mass])
    offset = rng.normal(scale=0.3, size=(*size, 3))
    gyration = np.sqrt(np.linalg.eigvalsh(inertia)[:, -1] / mass).reshape(size)
    offset = offset * np.minimum(1.0, 4.0 * gyration / np.linalg.norm(offset, axis=-1))[..., None]
    return ff.capture.Target(
        mass=mass.reshape(size),
        inertia=inertia.reshape((*size, 3, 3)),
        position=tip + offset,
        attitude=Rotation.random(count, random_state=rng).as_quat().reshape((*size, 4)),
        velocity=rng.normal(scale=0.5, size=(*size, 3)),
        angular_velocity=rng.normal(scale=0.3, size=(*size, 3)),
    )

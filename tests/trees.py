"""Random 3D space-robot trees for property and oracle tests.

The structure (arms, joints per arm, branches, fixed joints) is drawn by
hypothesis; the numbers (masses, inertias, axes, placements) come from a
seeded generator drawn by hypothesis too, so every example is reproducible.
"""

from __future__ import annotations

import numpy as np
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import freefloat as ff


def random_inertia(rng: np.random.Generator, mass: float) -> np.ndarray:
    """Inertia of a randomly rotated solid box: always physical (triangle inequality holds)."""
    a, b, c = rng.uniform(0.05, 1.0, size=3)
    principal = mass / 12.0 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])
    rot = Rotation.random(random_state=rng).as_matrix()
    return rot @ np.diag(principal) @ rot.T


def build_random_model(
    rng: np.random.Generator,
    joints_per_arm: list[int],
    branch_at: list[int | None],
    fixed_at: list[int | None],
    name: str = "random",
    prismatic: float = 0.0,
) -> ff.Model:
    """A spacecraft with len(joints_per_arm) arms.

    ``branch_at[m]``: index of the link of arm m after which a second 1-2 link
    branch starts (None: no branch). ``fixed_at[m]``: index of a link that is
    attached through an extra fixed joint and a massive intermediate body
    (None: no fixed joint). ``prismatic``: the probability that a joint slides (limits ±0.5 m)
    instead of turning.
    """
    b = ff.ModelBuilder(name)
    m0 = rng.uniform(50.0, 500.0)
    b.add_body("bus", mass=m0, inertia=random_inertia(rng, m0), com=rng.normal(scale=0.2, size=3))

    def link(parent: str, body: str, joint: str) -> None:
        m = rng.uniform(1.0, 50.0)
        b.add_body(body, mass=m, inertia=random_inertia(rng, m), com=rng.normal(scale=0.4, size=3))
        sliding = prismatic > 0.0 and rng.uniform() < prismatic
        b.add_joint(
            joint,
            parent=parent,
            child=body,
            origin=rng.normal(scale=0.5, size=3),
            rotation=Rotation.random(random_state=rng).as_matrix(),
            axis=rng.normal(size=3),
            type="prismatic" if sliding else "revolute",
            limits=(-0.5, 0.5) if sliding else (-np.pi, np.pi),
        )

    for arm, n in enumerate(joints_per_arm):
        parent = "bus"
        for k in range(n):
            body = f"a{arm}_l{k}"
            if fixed_at[arm] == k:
                mid = f"a{arm}_fixed{k}"
                m = rng.uniform(0.5, 5.0)
                b.add_body(mid, mass=m, inertia=random_inertia(rng, m), com=rng.normal(scale=0.2, size=3))
                b.add_joint(
                    f"a{arm}_fix{k}",
                    parent=parent,
                    child=mid,
                    origin=rng.normal(scale=0.3, size=3),
                    rotation=Rotation.random(random_state=rng).as_matrix(),
                    type="fixed",
                )
                parent = mid
            link(parent, body, f"a{arm}_q{k}")
            if branch_at[arm] == k:
                bp = body
                for j in range(int(rng.integers(1, 3))):
                    link(bp, f"a{arm}_b{j}", f"a{arm}_bq{j}")
                    bp = f"a{arm}_b{j}"
            parent = body
    model = b.build(source="tests/trees.py")
    return model


@st.composite
def random_trees(draw: st.DrawFn, max_arms: int = 3, max_joints: int = 7, prismatic: float = 0.0) -> ff.Model:
    """Hypothesis strategy: 1-3 arms, 1-7 joints per arm, optional branch and fixed joint per arm.

    ``prismatic`` > 0: each joint slides with that probability (and at least one does).
    """
    n_arms = draw(st.integers(1, max_arms))
    joints = [draw(st.integers(1, max_joints)) for _ in range(n_arms)]
    branch = [draw(st.one_of(st.none(), st.integers(0, n - 1))) for n in joints]
    fixed = [draw(st.one_of(st.none(), st.integers(0, n - 1))) for n in joints]
    seed = draw(st.integers(0, 2**32 - 1))
    model = build_random_model(np.random.default_rng(seed), joints, branch, fixed, prismatic=prismatic)
    if prismatic > 0.0:
        from hypothesis import assume

        assume(model.has_prismatic)
    return model

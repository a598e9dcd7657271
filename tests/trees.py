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
    sliding: tuple[int, int] | None = None,
    tools: bool = False,
) -> ff.Model:
    """A spacecraft with len(joints_per_arm) arms.

    ``branch_at[m]``: index of the link of arm m after which a second 1-2 link
    branch starts (None: no branch). ``fixed_at[m]``: index of a link that is
    attached through an extra fixed joint and a massive intermediate body
    (None: no fixed joint). ``prismatic``: the probability that a joint slides (limits ±0.5 m)
    instead of turning. ``sliding`` = (m, k): joint k of arm m slides whatever ``prismatic`` says.
    ``tools``: every leaf body holds an end effector at a random point of its frame (as a real arm holds
    its tool away from its last joint); otherwise the end effectors are the leaves' frame origins, on
    their last joint, which that joint then cannot move relative to its parent.
    """
    b = ff.ModelBuilder(name)
    m0 = rng.uniform(50.0, 500.0)
    b.add_body("bus", mass=m0, inertia=random_inertia(rng, m0), com=rng.normal(scale=0.2, size=3))

    parents: list[str] = []
    links: list[str] = []

    def link(parent: str, body: str, joint: str, forced: bool = False) -> None:
        m = rng.uniform(1.0, 50.0)
        b.add_body(body, mass=m, inertia=random_inertia(rng, m), com=rng.normal(scale=0.4, size=3))
        slides = (prismatic > 0.0 and rng.uniform() < prismatic) or forced
        parents.append(parent)
        links.append(body)
        b.add_joint(
            joint,
            parent=parent,
            child=body,
            origin=rng.normal(scale=0.5, size=3),
            rotation=Rotation.random(random_state=rng).as_matrix(),
            axis=rng.normal(size=3),
            type="prismatic" if slides else "revolute",
            limits=(-0.5, 0.5) if slides else (-np.pi, np.pi),
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
                parents.append(parent)
                parent = mid
            link(parent, body, f"a{arm}_q{k}", forced=sliding == (arm, k))
            if branch_at[arm] == k:
                bp = body
                for j in range(int(rng.integers(1, 3))):
                    link(bp, f"a{arm}_b{j}", f"a{arm}_bq{j}")
                    bp = f"a{arm}_b{j}"
            parent = body
    if tools:
        for leaf in (body for body in links if body not in parents):
            b.add_end_effector(f"{leaf}_tool", body=leaf, point=rng.normal(scale=0.3, size=3))
    model = b.build(source="tests/trees.py")
    return model


@st.composite
def random_trees(
    draw: st.DrawFn, max_arms: int = 3, max_joints: int = 7, prismatic: float = 0.0, tools: bool = False, min_joints: int = 1
) -> ff.Model:
    """Hypothesis strategy: 1-3 arms, 1-7 joints per arm (``min_joints`` at least), optional branch and fixed joint per arm.

    ``prismatic`` > 0: each joint slides with that probability, and one drawn joint always does (so every
    example has a sliding joint, none is rejected). ``tools``: see :func:`build_random_model`.
    """
    n_arms = draw(st.integers(1, max_arms))
    joints = [draw(st.integers(min_joints, max_joints)) for _ in range(n_arms)]
    branch = [draw(st.one_of(st.none(), st.integers(0, n - 1))) for n in joints]
    fixed = [draw(st.one_of(st.none(), st.integers(0, n - 1))) for n in joints]
    seed = draw(st.integers(0, 2**32 - 1))
    sliding = None
    if prismatic > 0.0:
        arm = draw(st.integers(0, n_arms - 1))
        sliding = (arm, draw(st.integers(0, joints[arm] - 1)))
    model = build_random_model(np.random.default_rng(seed), joints, branch, fixed, prismatic=prismatic, sliding=sliding, tools=tools)
    assert model.has_prismatic or prismatic == 0.0
    return model

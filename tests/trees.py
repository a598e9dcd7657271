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
    mimic: float = 0.0,
    gripper_like: bool = False,
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
    ``mimic``: the probability that a joint (not the first) is a mimic joint of an earlier joint of its type (a mimic
    joint too, then a chain), anywhere in the tree, multiplier in ±[0.3, 2], offset in [-0.3, 0.3]; one always is when an
    earlier joint has its type. ``gripper_like``: mimic joints move leaf bodies only, and follow the joint of an
    ancestor or of a sibling (as the fingers of real grippers).
    """
    b = ff.ModelBuilder(name)
    m0 = rng.uniform(50.0, 500.0)
    b.add_body("bus", mass=m0, inertia=random_inertia(rng, m0), com=rng.normal(scale=0.2, size=3))

    parents: list[str] = []
    links: list[str] = []
    kinds: list[tuple[str, str]] = []  # (joint, type) of the movable joints, in the order added
    joint_parent: dict[str, str] = {}  # joint -> its parent body
    joint_child: dict[str, str] = {}  # joint -> its child body
    body_parent: dict[str, str] = {}  # body -> its parent body

    def link(parent: str, body: str, joint: str, forced: bool = False) -> None:
        m = rng.uniform(1.0, 50.0)
        b.add_body(body, mass=m, inertia=random_inertia(rng, m), com=rng.normal(scale=0.4, size=3))
        slides = (prismatic > 0.0 and rng.uniform() < prismatic) or forced
        parents.append(parent)
        links.append(body)
        kinds.append((joint, "prismatic" if slides else "revolute"))
        joint_parent[joint] = parent
        joint_child[joint] = body
        body_parent[body] = parent
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
                body_parent[mid] = parent
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
    if mimic > 0.0:
        candidates = []  # (joint, its possible leaders)
        for i, (joint, kind) in enumerate(kinds):
            leaders = [name for name, other in kinds[:i] if other == kind]
            if gripper_like:  # a leaf body's joint, following an ancestor's joint or a sibling's
                if joint_child[joint] in body_parent.values():
                    continue
                path, body = set(), joint_parent[joint]
                while body in body_parent:
                    path.add(body)
                    body = body_parent[body]
                leaders = [name for name in leaders if joint_child[name] in path or joint_parent[name] == joint_parent[joint]]
            if leaders:
                candidates.append((joint, leaders))
        forced = int(rng.integers(len(candidates))) if candidates else -1
        for c, (joint, leaders) in enumerate(candidates):
            if rng.uniform() < mimic or c == forced:
                sign = rng.choice([-1.0, 1.0])
                b.add_mimic(joint, leader=str(rng.choice(leaders)), multiplier=sign * rng.uniform(0.3, 2.0), offset=rng.uniform(-0.3, 0.3))
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


@st.composite
def random_mimic_trees(
    draw: st.DrawFn, max_arms: int = 3, max_joints: int = 5, prismatic: float = 0.0, tools: bool = True, gripper_like: bool = False
) -> ff.Model:
    """Hypothesis strategy: the trees of :func:`random_trees` (at least two joints) with mimic joints (``mimic=0.3``
    in :func:`build_random_model`): at least one (when a joint can have a leader), chains and leaders in other arms
    included; ``gripper_like``: see there."""
    n_arms = draw(st.integers(1, max_arms))
    joints = [draw(st.integers(2 if n_arms == 1 else 1, max_joints)) for _ in range(n_arms)]
    branch = [draw(st.one_of(st.none(), st.integers(0, n - 1))) for n in joints]
    fixed = [draw(st.one_of(st.none(), st.integers(0, n - 1))) for n in joints]
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    return build_random_model(
        rng, joints, branch, fixed, name="mimic", prismatic=prismatic, tools=tools, mimic=0.3, gripper_like=gripper_like
    )


def random_urdf(rng: np.random.Generator, joints_per_arm: list[int], prismatic: float = 0.3) -> str:
    """A URDF written here from raw random numbers (never through a freefloat model or writer), for oracles that build
    their robot from the file itself (``pinocchio.buildModelFromUrdf``) while freefloat reads it with ``ff.load``.

    A spacecraft link ``bus`` with ``len(joints_per_arm)`` serial arms of revolute and (probability ``prismatic``)
    prismatic joints, random placements, axes and inertias (about a CM off the link origin, in rotated axes); each arm
    ends in a massless ``a{m}_tool`` link on a fixed joint, off its last link's origin: the end effectors, points of
    the last links away from their frame origins."""

    def f(values: np.ndarray) -> str:
        return " ".join(f"{x:.17g}" for x in np.ravel(values))

    def inertial(mass: float, spread: float) -> str:
        i = random_inertia(rng, mass)
        rpy = Rotation.random(random_state=rng).as_euler("xyz")
        com = rng.normal(scale=spread, size=3)
        # the tensor is given in the inertial frame's axes (turned by rpy): write R^T I R so that the link axes see I
        rot = Rotation.from_euler("xyz", rpy).as_matrix()
        j = rot.T @ i @ rot
        return (
            f'<inertial><origin xyz="{f(com)}" rpy="{f(rpy)}"/><mass value="{mass:.17g}"/>'
            f'<inertia ixx="{j[0, 0]:.17g}" ixy="{j[0, 1]:.17g}" ixz="{j[0, 2]:.17g}" '
            f'iyy="{j[1, 1]:.17g}" iyz="{j[1, 2]:.17g}" izz="{j[2, 2]:.17g}"/>'
            "</inertial>"
        )

    parts = [f'<robot name="raw"><link name="bus">{inertial(float(rng.uniform(100.0, 500.0)), 0.2)}</link>']
    for arm, n in enumerate(joints_per_arm):
        parent = "bus"
        for k in range(n):
            body = f"a{arm}_l{k}"
            slides = rng.uniform() < prismatic
            axis = rng.normal(size=3)
            limit = '<limit lower="-0.5" upper="0.5" effort="100" velocity="10"/>' if slides else ""
            kind = "prismatic" if slides else "continuous"
            parts.append(f'<link name="{body}">{inertial(float(rng.uniform(1.0, 50.0)), 0.4)}</link>')
            parts.append(
                f'<joint name="a{arm}_q{k}" type="{kind}"><parent link="{parent}"/><child link="{body}"/>'
                f'<origin xyz="{f(rng.normal(scale=0.5, size=3))}" rpy="{f(Rotation.random(random_state=rng).as_euler("xyz"))}"/>'
                f'<axis xyz="{f(axis / np.linalg.norm(axis))}"/>{limit}</joint>'
            )
            parent = body
        tool = f"a{arm}_tool"
        parts.append(f'<link name="{tool}"/>')
        parts.append(
            f'<joint name="a{arm}_tool_mount" type="fixed"><parent link="{parent}"/><child link="{tool}"/>'
            f'<origin xyz="{f(rng.uniform(0.2, 0.5, size=3) * rng.choice([-1.0, 1.0], size=3))}" rpy="0 0 0"/></joint>'
        )
    parts.append("</robot>")
    return "".join(parts)

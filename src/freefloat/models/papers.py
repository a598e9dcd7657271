"""The example systems of Papadopoulos & Dubowsky 1991 (Table I) and Papadopoulos 1992 (Table I).

Both papers describe planar systems: link lengths l_i (CM to inboard joint)
and r_i (CM to outboard joint), masses and one moment of inertia I_i about
the axis normal to the plane. Angle convention (1992 eqs. 18, 20): link k of
arm m has absolute angle θ + q1 + ... + qk, zero along the spacecraft x axis,
for every arm. Each link is a body whose frame sits on its inboard joint with
the link along +x; the spacecraft CM is the origin of the spacecraft frame.

Out-of-plane inertias (not given by the papers; they do not enter any planar
result): the spacecraft is a cube, I_xx = I_yy = I_zz = I_0 (I_0 = m (1² + 1²)/12
is exactly a 1 m cube); each link is a slender cylinder of radius 0.05 m along
its x axis: I_xx = m 0.05² / 2, I_yy = I_zz = I_i as printed.
"""

from __future__ import annotations

import numpy as np

from ..core.builder import ModelBuilder
from ..core.model import Model

__all__ = ["papadopoulos1991", "papadopoulos1992", "planar_link"]

#: Radius of the slender cylinder used for the links' axial inertia (m).
LINK_RADIUS = 0.05


def planar_link(mass: float, inertia_zz: float) -> np.ndarray:
    """Inertia (about the CM) of a paper link along x: [m r²/2, I, I] with r = 0.05 m."""
    return np.array([mass * LINK_RADIUS**2 / 2.0, inertia_zz, inertia_zz])


def _add_arm(
    b: ModelBuilder, prefix: str, base: str, mount: tuple[float, float, float], links: list[tuple[float, float, float, float]]
) -> None:
    """Add a planar arm: links (l, r, m, I) mounted at ``mount`` (spacecraft frame)."""
    parent, origin = base, mount
    for k, (l_in, r_out, m, inertia) in enumerate(links, start=1):
        body = f"{prefix}link{k}" if prefix else f"link{k}"
        last = k == len(links)
        b.add_body(
            body,
            mass=m,
            inertia=planar_link(m, inertia),
            com=(l_in, 0.0, 0.0),
            end_effector=(l_in + r_out, 0.0, 0.0) if last else None,
            end_effector_name=f"{prefix}ee" if last else None,
        )
        b.add_joint(f"{prefix}q{k}", parent=parent, child=body, origin=origin, axis=(0.0, 0.0, 1.0), type="continuous")
        parent, origin = body, (l_in + r_out, 0.0, 0.0)


def papadopoulos1991() -> Model:
    """The §V example of Papadopoulos & Dubowsky 1991 (their Table I).

    A planar two-link arm on a spacecraft: body 0 (r = 0.5 m, 40 kg, 6.667 kg m²),
    link 1 (l = r = 0.5 m, 4 kg, 0.333 kg m²), link 2 (l = r = 0.5 m, 3 kg,
    0.250 kg m²). Joints ``q1``, ``q2``; end effector ``ee``.
    """
    b = ModelBuilder("papadopoulos1991")
    b.add_body("spacecraft", mass=40.0, inertia=6.667)
    _add_arm(b, "", "spacecraft", (0.5, 0.0, 0.0), [(0.5, 0.5, 4.0, 0.333), (0.5, 0.5, 3.0, 0.250)])
    return b.build(source="built-in: Papadopoulos & Dubowsky 1991, Table I")


def papadopoulos1992(arms: int = 2) -> Model:
    """The two-arm system of Papadopoulos 1992 (Tables Ia, Ib); ``arms=1`` drops manipulator 2.

    Spacecraft 400 kg, 66.67 kg m², arms mounted at r_0⁽¹⁾ = +0.5 m and
    r_0⁽²⁾ = -0.5 m on the spacecraft x axis (the signs that Table II's
    α⁽¹⁾ = 0.5, α⁽²⁾ = -0.5 imply). Each arm: link 1 (l = r = 0.5 m, 40 kg,
    3.33 kg m²), link 2 (l = r = 0.5 m, 30 kg, 2.5 kg m²). Joints
    ``arm1_q1, arm1_q2, arm2_q1, arm2_q2``; end effectors ``arm1_ee, arm2_ee``.
    """
    if arms not in (1, 2):
        raise ValueError(f"arms: the 1992 system has 1 or 2 manipulators, got {arms!r}")
    b = ModelBuilder("papadopoulos1992" if arms == 2 else "papadopoulos1992_one_arm")
    b.add_body("spacecraft", mass=400.0, inertia=66.67)
    arm = [(0.5, 0.5, 40.0, 3.33), (0.5, 0.5, 30.0, 2.5)]
    _add_arm(b, "arm1_", "spacecraft", (0.5, 0.0, 0.0), arm)
    if arms == 2:
        _add_arm(b, "arm2_", "spacecraft", (-0.5, 0.0, 0.0), arm)
    return b.build(source=f"built-in: Papadopoulos 1992, Table I ({arms} arm{'s' if arms == 2 else ''})")

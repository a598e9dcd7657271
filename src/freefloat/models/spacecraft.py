"""A realistic 3D free-flyer: a 1500 kg spacecraft bus with a 7-DOF anthropomorphic arm.

Used by the benchmarks and as a 3D, redundant test system (its J* is 6 x 7, so
its singularity measure is :func:`freefloat.manipulability`, sqrt det(J* J*ᵀ)).
"""

from __future__ import annotations

import numpy as np

from ..core.builder import ModelBuilder
from ..core.model import Model

__all__ = ["spacecraft_7dof"]

#: Bus inertia about its CM, bus axes (kg m²): a 1500 kg box of about 2.0 x 1.8 x 2.4 m
#: with off-diagonal products from asymmetric equipment and tanks.
BUS_INERTIA = np.array(
    [
        [1125.0, -38.0, 22.0],
        [-38.0, 1220.0, 31.0],
        [22.0, 31.0, 905.0],
    ]
)

#: Per link: (joint-to-next-joint length along the arm axis in m, mass in kg, tube radius in m, lateral CM offset in m).
#: Lengths: KUKA LBR iiwa 14 R820 joint spacing (0.36, 0.2045, 0.2155, 0.1845, 0.2155, 0.081, 0.126 m) scaled by 2.
#: Masses: the iiwa 14 link masses (4, 4, 3, 2.7, 1.7, 1.8, 0.3 kg) scaled by 3, the last link with a 2 kg tool flange.
ARM_LINKS: tuple[tuple[float, float, float, float], ...] = (
    (0.720, 12.0, 0.09, 0.030),
    (0.409, 12.0, 0.09, -0.025),
    (0.431, 9.0, 0.08, 0.020),
    (0.369, 8.1, 0.08, -0.020),
    (0.431, 5.1, 0.07, 0.015),
    (0.162, 5.4, 0.07, 0.0),
    (0.252, 2.0, 0.05, 0.0),
)

#: Joint axes in the link frames (alternating roll / pitch, as the iiwa and ERA-style S-R-S arms).
ARM_AXES: tuple[tuple[float, float, float], ...] = (
    (0.0, 0.0, 1.0),
    (0.0, 1.0, 0.0),
    (0.0, 0.0, 1.0),
    (0.0, -1.0, 0.0),
    (0.0, 0.0, 1.0),
    (0.0, 1.0, 0.0),
    (0.0, 0.0, 1.0),
)

#: Joint limits (rad): the iiwa 14's ±170°, ±120°, ±170°, ±120°, ±170°, ±120°, ±175°.
ARM_LIMITS_DEG: tuple[float, ...] = (170.0, 120.0, 170.0, 120.0, 170.0, 120.0, 175.0)

#: Arm mount on the bus (bus frame, m) and the mount rotation taking the arm's z axis to the bus +x face normal.
ARM_MOUNT = (1.0, 0.3, 0.45)
ARM_MOUNT_ROTATION = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])


def _tube_inertia(mass: float, length: float, radius: float) -> np.ndarray:
    """Inertia about the CM of a solid cylinder along z: [m(3r² + L²)/12, same, m r²/2]."""
    transverse = mass * (3.0 * radius**2 + length**2) / 12.0
    return np.array([transverse, transverse, mass * radius**2 / 2.0])


def spacecraft_7dof() -> Model:
    """A 1500 kg spacecraft bus with a 7-DOF anthropomorphic (S-R-S) arm, 3D.

    Bus: 1500 kg, CM at (0.02, -0.01, 0.05) m from the bus frame origin, full
    3x3 inertia ``BUS_INERTIA`` (principal moments about 0.9-1.25 10³ kg m²:
    a 2.0 x 1.8 x 2.4 m box with products of inertia of a few percent, the
    order of a small GEO / servicing spacecraft).

    Arm (``ARM_LINKS``): kinematics of a KUKA LBR iiwa 14 R820 (joint axes
    alternating roll/pitch, z, y, z, -y, z, y, z; straight along its z axis at
    q = 0, a singular configuration) scaled by 2 in length: 2.77 m from the
    base flange to the tool tip, 2.05 m from the shoulder (joint 2), the size
    of a servicing arm between DLR's CAESAR and the ERA; link masses are the
    iiwa's scaled by 3 (2-12 kg, 53.6 kg in all, the last link a 2 kg tool
    flange). Each link is a solid
    cylinder (radius 5-9 cm) whose CM sits mid-link with a small lateral
    offset, so the inertias are not symmetric about the arm axis. Joint limits
    are the iiwa's (±170°, ±120°, ±170°, ±120°, ±170°, ±120°, ±175°).

    The arm is mounted at ``ARM_MOUNT`` = (1.0, 0.3, 0.45) m on the bus +x
    face, its base z axis along bus +x. Joints ``j1``..``j7``; one end effector
    ``tool`` at the end of link 7. N = 7 and J* is 6 x 7 (redundant):
    :func:`freefloat.jacobian_determinant` raises for it; use
    :func:`freefloat.manipulability`.

    The numbers are representative, chosen for realism of mass ratio (arm/bus
    ≈ 3.6 %), reach and inertia coupling, not taken from one flight system.
    """
    b = ModelBuilder("spacecraft_7dof")
    b.add_body("bus", mass=1500.0, inertia=BUS_INERTIA, com=(0.02, -0.01, 0.05))
    parent, origin = "bus", ARM_MOUNT
    rotation: np.ndarray | None = ARM_MOUNT_ROTATION
    n = len(ARM_LINKS)
    for k, ((length, mass, radius, offset), axis, limit) in enumerate(zip(ARM_LINKS, ARM_AXES, ARM_LIMITS_DEG, strict=True), start=1):
        body = f"link{k}"
        last = k == n
        b.add_body(
            body,
            mass=mass,
            inertia=_tube_inertia(mass, length, radius),
            com=(offset, 0.5 * offset, 0.5 * length),
            end_effector=(0.0, 0.0, length) if last else None,
            end_effector_name="tool" if last else None,
        )
        lim = np.deg2rad(limit)
        b.add_joint(f"j{k}", parent=parent, child=body, origin=origin, rotation=rotation, axis=axis, type="revolute", limits=(-lim, lim))
        parent, origin, rotation = body, (0.0, 0.0, length), None
    return b.build(source="built-in: freefloat.models.spacecraft_7dof (iiwa-style 7-DOF arm on a 1500 kg bus)")

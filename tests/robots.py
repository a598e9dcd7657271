"""Real robot descriptions from the ``example-robot-data`` package, wrapped as space robots.

Each URDF is used as shipped, with one edit made here in the XML (and nowhere in freefloat): a
500 kg spacecraft link is added as the new root, holding the robot's root link by a fixed joint
0.5 m above its frame origin. ``<mimic>`` elements stay (the Panda's second finger, Baxter's
grippers): freefloat reads them as dependent coordinates, as Pinocchio does with ``mimic=True``.
A missing package fails the tests.
``load_real`` loads one and checks what freefloat drops from it, with a warning: ``UNMODELLED``.
"""

from __future__ import annotations

import xml.etree.ElementTree as ElementTree
from importlib.metadata import distribution
from pathlib import Path
from typing import Any

import pytest

import freefloat as ff
from freefloat.core.errors import UnmodelledElementWarning

ROBOTS = Path(str(distribution("example-robot-data").locate_file("cmeel.prefix/share/example-robot-data/robots")))

#: name -> (URDF path under ROBOTS, the end effectors to name; None = every leaf link)
REAL_ROBOTS: dict[str, tuple[str, list[str] | None]] = {
    "ur5": ("ur_description/urdf/ur5_robot.urdf", ["tool0"]),
    "kinova": ("kinova_description/robots/kinova.urdf", ["j2s6s200_end_effector"]),
    "panda": ("panda_description/urdf/panda.urdf", ["panda_hand_tcp"]),
    "baxter": ("baxter_description/urdf/baxter.urdf", ["left_gripper", "right_gripper"]),
}

#: name -> the elements of its file that act on the dynamics and that freefloat drops, each with an
#: UnmodelledElementWarning (docs/model-files.md, "What is read, ignored and dropped"): the Kinova's
#: 160:1 gear reductions, the Panda's and Baxter's joint damping. The UR5's are all neutral.
UNMODELLED: dict[str, tuple[str, ...]] = {
    "ur5": (),
    "kinova": ("URDF <transmission> <mechanicalReduction> other than 1",),
    "panda": (),  # its <dynamics damping> is modelled (Model.joint_damping)
    "baxter": (),
}


def load_real(name: str, path: Path, **kwargs: Any) -> ff.Model:
    """``ff.load(path, **kwargs)`` of the robot ``name`` (a file from :func:`spacecraft_urdf`), asserting that the
    elements in ``UNMODELLED[name]``, and only those, warn and are recorded in ``Model.unmodelled``."""
    expected = UNMODELLED[name]
    if not expected:
        model = ff.load(path, **kwargs)
    else:
        with pytest.warns(UnmodelledElementWarning) as caught:
            model = ff.load(path, **kwargs)
        assert len(caught) == len(expected) and all(e in str(w.message) for e, w in zip(expected, caught, strict=True))
    assert tuple(u["element"] for u in model.unmodelled) == expected
    return model


def spacecraft_urdf(relative: str, directory: Path) -> Path:
    """Write the robot at ``ROBOTS / relative`` under a spacecraft root link into ``directory``; return the path."""
    source = ROBOTS / relative
    assert source.is_file(), f"example-robot-data has no {relative}"
    root = ElementTree.fromstring(source.read_text(encoding="utf-8"))
    children = {j.find("child").get("link") for j in root.findall("joint")}  # type: ignore[union-attr]
    roots = [link.get("name") for link in root.findall("link") if link.get("name") not in children]
    assert len(roots) == 1, f"{relative}: root links {roots}"
    bus = ElementTree.SubElement(root, "link", name="spacecraft")
    inertial = ElementTree.SubElement(bus, "inertial")
    ElementTree.SubElement(inertial, "origin", xyz="0.1 -0.05 -0.4", rpy="0 0 0")
    ElementTree.SubElement(inertial, "mass", value="500")
    ElementTree.SubElement(inertial, "inertia", ixx="80", ixy="1.5", ixz="-2", iyy="90", iyz="0.5", izz="60")
    mount = ElementTree.SubElement(root, "joint", name="mount", type="fixed")
    ElementTree.SubElement(mount, "parent", link="spacecraft")
    ElementTree.SubElement(mount, "child", link=str(roots[0]))
    ElementTree.SubElement(mount, "origin", xyz="0 0 0.5", rpy="0 0 0.3")
    out = Path(directory) / Path(relative).name
    out.write_text(ElementTree.tostring(root, encoding="unicode"), encoding="utf-8")
    return out

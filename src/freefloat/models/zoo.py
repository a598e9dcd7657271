"""The model zoo: space manipulators with published parameters, each with its provenance.

Each model is a TOML file in ``freefloat/models/zoo/`` next to a Markdown file that gives the source
of every number (publication and table, or repository, path and commit), the licence, what was
chosen where nothing is published, and every correction of the published numbers and why. A
correction of a non-physical published inertia is declared in the file (``[[corrections]]``: the
published value and the reason), computed when loading (the nearest physical inertia) and listed in
``Model.corrections`` (``freefloat inspect NAME`` prints it). Each model is checked against
Pinocchio in ``tests/models/test_zoo.py``.
"""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path

from ..core.model import Model
from ..io.model_files import load

__all__ = ["ZOO", "astrobee_arm", "dual_arm_servicer", "ets7", "provenance", "ssrms_station"]

ZOO: dict[str, tuple[str, str]] = {
    "ssrms-station": (
        "ssrms_iss",
        "SSRMS (Canadarm2) 7-DOF, 1505 kg, on a 420 t station: links from space-ros/simulation (Apache-2.0, "
        "after Nguyen & Hughes 1994); station inertia estimated",
    ),
    "ets7": (
        "ets7",
        "ETS-VII (NASDA 1997): 2552 kg satellite, 6-DOF arm; bMSd model_ETS7.m (after Yoshida & Abiko 2002); "
        "3 link inertias corrected (triangle inequality)",
    ),
    "dual-arm-servicer": (
        "dual_gen3_servicer",
        "250 kg servicer bus (chosen) with two Kinova Gen3 7-DOF arms (ros_kortex URDF, BSD-3-Clause)",
    ),
    "astrobee-arm": (
        "astrobee_perching_arm",
        "NASA Astrobee (9.58 kg, flight mass properties) with its 2-DOF perching arm (nasa/astrobee, Apache-2.0); "
        "arm inertias replaced (URDF placeholders)",
    ),
}
"""The model zoo by CLI name: (file stem of the shipped TOML and provenance page, one-line provenance)."""


def _path(stem: str, suffix: str) -> Path:
    return Path(str(files(__package__).joinpath("zoo", f"{stem}{suffix}")))


def _load(name: str) -> Model:
    return load(_path(ZOO[name][0], ".toml"))


def provenance(name: str) -> str:
    """The provenance notes (Markdown) of a zoo model: sources, licence, choices and corrections."""
    return _path(ZOO[name][0], ".md").read_text(encoding="utf-8")


def ssrms_station() -> Model:
    """SSRMS (Canadarm2) 7-DOF arm on an ISS-sized station (see :func:`provenance` ``("ssrms-station")``)."""
    return _load("ssrms-station")


def ets7() -> Model:
    """ETS-VII: the NASDA test satellite and its 6-DOF arm, published mass properties with 3 inertias corrected."""
    return _load("ets7")


def dual_arm_servicer() -> Model:
    """A 250 kg servicer with two Kinova Gen3 7-DOF arms (two end effectors, J* 12 x 14)."""
    return _load("dual-arm-servicer")


def astrobee_arm() -> Model:
    """NASA Astrobee with its 2-DOF perching arm: a small free-flyer with a short arm."""
    return _load("astrobee-arm")

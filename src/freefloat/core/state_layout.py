"""The flat state vector, declared once: its blocks in order, and the offsets and sizes written from them.

The integrators, the compiled kernels and the recorded trajectories see a state as one vector x (MuJoCo's
``mj_stateSize`` and ``jnt_qposadr`` do the same for its state):

    x = [r_cm (3), v_cm (3), attitude (4), omega (3), q (n), qdot (n)] and, in a run that integrates it, the energy
    the joints' damping and friction have dissipated (1), last

with n the joint coordinates the integrator sees: N, and N + W for a model with W reaction wheels (their angles
after the joints' in q, their speeds after the joints' rates in qdot: :mod:`freefloat.core.wheels`).
:data:`BLOCKS` is the declaration; every offset is read from the names below (module-level integers: numba compiles
them in as constants), never typed as a number: ``x[Q_AT + j]`` is q_j, ``x[qdot_at(n) + j]`` its rate,
``x[span("omega", n)]`` the spacecraft's angular velocity. A new block is one line in :data:`BLOCKS` (and a name
below where code reads it).
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "ATTITUDE_AT",
    "BLOCKS",
    "OMEGA_AT",
    "Q_AT",
    "R_CM_AT",
    "V_CM_AT",
    "Block",
    "coordinates",
    "dissipated_at",
    "qdot_at",
    "span",
    "start",
    "state_length",
]


@dataclass(frozen=True)
class Block:
    """A block of the flat state: ``fixed`` entries for any model plus ``per_coordinate`` entries per joint coordinate
    (n), what it is, and whether a state may lack it (``optional``: only the last block)."""

    name: str
    fixed: int
    per_coordinate: int
    doc: str
    optional: bool = False


#: The flat state, in order (module docstring).
BLOCKS: tuple[Block, ...] = (
    Block("r_cm", 3, 0, "system CM position, inertial frame (m)"),
    Block("v_cm", 3, 0, "system CM velocity, inertial frame (m/s)"),
    Block("attitude", 4, 0, "spacecraft attitude T0 (frame 0 -> I), unit quaternion [x, y, z, w]"),
    Block("omega", 3, 0, "spacecraft angular velocity, spacecraft frame (rad/s)"),
    Block("q", 0, 1, "joint values (rad, m), then the wheel angles"),
    Block("qdot", 0, 1, "joint rates, then the wheel speeds relative to the spacecraft"),
    Block("dissipated", 1, 0, "energy dissipated by the joints' damping and friction since the start (J)", optional=True),
)


def _start(name: str) -> tuple[int, int]:
    """(fixed, per coordinate) part of where block ``name`` starts; ``""``: the end of the state without the optional block."""
    fixed = per = 0
    for b in BLOCKS:
        if b.name == name or (not name and b.optional):
            return fixed, per
        fixed, per = fixed + b.fixed, per + b.per_coordinate
    if name:
        raise KeyError(f"the flat state has no block {name!r}; its blocks are {[b.name for b in BLOCKS]}")
    return fixed, per


def _fixed(name: str) -> int:
    fixed, per = _start(name)
    assert per == 0, name  # a block after q: its start depends on n (a function below)
    return fixed


#: Where the blocks that start at the same place for every model begin (x[R_CM_AT : R_CM_AT + 3] is r_cm).
R_CM_AT = _fixed("r_cm")
V_CM_AT = _fixed("v_cm")
ATTITUDE_AT = _fixed("attitude")
OMEGA_AT = _fixed("omega")
Q_AT = _fixed("q")
_QDOT = _start("qdot")
_DISSIPATED = _start("dissipated")
_END = _start("")
_SIZE = {b.name: (b.fixed, b.per_coordinate) for b in BLOCKS}


def qdot_at(n: int) -> int:
    """Where qdot starts in the flat state of ``n`` joint coordinates."""
    return _QDOT[0] + _QDOT[1] * n


def dissipated_at(n: int) -> int:
    """Where the dissipated energy is in the flat state of ``n`` joint coordinates (when it is there: its last slot)."""
    return _DISSIPATED[0] + _DISSIPATED[1] * n


def state_length(n: int, dissipated: bool = False) -> int:
    """The length of the flat state of ``n`` joint coordinates, with the dissipated energy's slot or without it."""
    return _END[0] + _END[1] * n + (1 if dissipated else 0)


def coordinates(length: int) -> int:
    """n, the joint coordinates of a flat state of ``length`` (with the dissipated energy's slot or without it)."""
    return (length - _END[0]) // _END[1]


def start(name: str, n: int) -> int:
    """Where block ``name`` starts in the flat state of ``n`` joint coordinates."""
    fixed, per = _start(name)
    return fixed + per * n


def span(name: str, n: int) -> slice:
    """The slice of block ``name`` in the flat state of ``n`` joint coordinates: ``x[..., span("q", n)]`` is q."""
    at = start(name, n)
    fixed, per = _SIZE[name]
    return slice(at, at + fixed + per * n)

"""Optional compiled dynamics (numba): forward dynamics, H+, C+, RK4 steps and batched rollouts.

Used by :func:`freeflyer.simulate` (fixed-step RK4) and :func:`freeflyer.rollout` when numba is
installed (the ``fast`` extra) and no external wrenches are given; the numpy path of
:mod:`freeflyer.dynamics` is the reference and gives the same numbers (to rounding).

How. The equations of motion are written once below as scalar code on the tree, in the
spacecraft frame (every spatial vector at the spacecraft frame origin O, so composite inertias
and forces add without transforms):

* kinematics: body rotations (Rodrigues, as :mod:`freeflyer.kinematics`), joint axes u_k,
  joint points p_k and the motion axes S_k = [u_k; p_k x u_k];
* H+ (1991 eq. 15) by the composite-rigid-body algorithm: the floating-base mass matrix at O in
  [v_O, omega0, qdot], then the CM velocity is eliminated by the Schur complement of its M 1
  block, A = H_yy - B^T B / M with B the linear-momentum rows (this is the change of
  coordinates v_O -> rdot_cm of docs/dynamics.md, section 7);
* C+ - Q (1991 eq. 19) by Newton-Euler with v_O = 0 and zero base linear acceleration, the
  thrusters as a wrench on body 0 and the uniform-acceleration correction delta = -f_O / M of
  :mod:`freeflyer.recursive` (docs/dynamics.md, section 4);
* forward dynamics: A [d/dt omega0; qddot] = -(C+ - Q) by a Cholesky factorisation, and
  rddot_cm = T0 f_S / M; the state derivative adds the quaternion rate (``simulate._derivative``).

This code is *traced* once per model with the scalars of :class:`freeflyer._batch.Tape`
(constant folding: axis-aligned joints, planar systems and diagonal inertias cost nothing;
common subexpressions; dead code removed) and emitted as straight-line numba code inside a loop
over a block of ``LANES`` trajectories (structure of arrays, the batch axis last, so LLVM
vectorises across trajectories). sin and cos use the table and short series of
:func:`freeflyer._batch.sincos`. RK4 drivers, a batched rollout with a joint PD controller
(gains per trajectory, optional open-loop feed-forward) and ``prange`` over blocks of
trajectories are emitted with it. The generated source is written to a cache folder and imported
from there, so numba's on-disk cache (``cache=True``) keeps the machine code between processes.
"""

from __future__ import annotations

import hashlib
import importlib.util
import itertools
import math
import os
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from ..core.model import Model
from . import _batch
from ._numba_programs import available

__all__ = ["LANES", "Kernels", "available", "enabled", "kernels"]

#: Trajectories (or configurations) per block: one lane each, the batch axis innermost.
LANES = 16

Scalar = Any  # a float or a traced freeflyer._batch.Sym
Vec = list[Any]


def enabled() -> bool:
    """numba installed and not switched off by ``FREEFLYER_NUMBA=0``."""
    return os.environ.get("FREEFLYER_NUMBA", "1") != "0" and available()


BACKENDS = ("auto", "numpy", "numba")


def use_compiled(backend: str, external: Any = None) -> bool:
    """Whether a fixed-step simulation runs on the compiled kernels.

    ``backend``: ``"auto"`` (numba when installed and enabled, and no external wrenches),
    ``"numpy"`` (the reference path) or ``"numba"`` (an error when it cannot be used).
    """
    from .dynamics import _wrenches

    if backend not in BACKENDS:
        raise ValueError(f"backend: expected 'auto', 'numpy' or 'numba', got {backend!r}")
    if backend == "numpy":
        return False
    if _wrenches(external):
        if backend == "numba":
            raise ValueError("backend='numba' does not handle external wrenches; use backend='numpy' or 'auto'")
        return False
    if backend == "numba":
        if not available():
            raise ImportError("backend='numba' needs numba: pip install freeflyer[fast]")
        return True
    return enabled()


# ----------------------------------------------------------------- scalar 3-vector algebra
def _cross(a: Vec, b: Vec) -> Vec:
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _dot(a: Vec, b: Vec) -> Scalar:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _add(a: Vec, b: Vec) -> Vec:
    return [a[0] + b[0], a[1] + b[1], a[2] + b[2]]


def _sub(a: Vec, b: Vec) -> Vec:
    return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]


def _scale(a: Vec, s: Scalar) -> Vec:
    return [a[0] * s, a[1] * s, a[2] * s]


def _matvec(m: list[Vec], v: Vec) -> Vec:
    return [_dot(m[0], v), _dot(m[1], v), _dot(m[2], v)]


def _matmul(a: list[Vec], b: list[Vec]) -> list[Vec]:
    return [[a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j] for j in range(3)] for i in range(3)]


def _sym_mv(s: list[Vec], v: Vec) -> Vec:
    """Symmetric 3x3 (full list form) times a vector."""
    return _matvec(s, v)


def _sqrt(x: Scalar) -> Scalar:
    if isinstance(x, _batch.Sym):
        return x.tape.sqrt(x)
    return math.sqrt(x)


def _floats(arr: np.ndarray) -> Any:
    return np.asarray(arr, dtype=float).tolist()


# ----------------------------------------------------------------- the equations, once
class _Tree:
    """Per-body kinematics and mass distribution at O, spacecraft frame, for one configuration."""

    def __init__(self, model: Model, sin: Sequence[Scalar], cos: Sequence[Scalar]) -> None:
        nb = model.n_bodies
        parent = [int(p) for p in model.parent]
        basis = [_floats(model.rotation_basis[i]) for i in range(3)]
        origin = _floats(model.joint_origin)
        axis_in_parent = _floats(np.einsum("kij,kj->ki", model.joint_rotation, model.joint_axis))
        com = _floats(model.com)
        inertia = _floats(model.inertia)
        mass = [float(m) for m in model.mass]
        eye = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
        rot: list[Any] = [eye] * nb
        pos: list[Vec] = [[0.0, 0.0, 0.0]] * nb
        axis: list[Vec] = [[0.0, 0.0, 0.0]] * nb
        moment: list[Vec] = [[0.0, 0.0, 0.0]] * nb  # p_k x u_k: linear part of S_k at O
        for k in range(1, nb):
            j, p = k - 1, parent[k]
            s, c = sin[j], 1.0 - cos[j]
            local = [[basis[0][j][a][b] + s * basis[1][j][a][b] + c * basis[2][j][a][b] for b in range(3)] for a in range(3)]
            rot[k] = local if p == 0 else _matmul(rot[p], local)
            pos[k] = _add(pos[p], _matvec(rot[p], origin[k]))
            axis[k] = _matvec(rot[p], axis_in_parent[k])
            moment[k] = _cross(pos[k], axis[k])
        self.rot, self.pos, self.axis, self.moment = rot, pos, axis, moment
        # mass m, first moment h = m s (s the CM from O) and inertia about O per body
        self.mass = mass
        self.first: list[Vec] = []
        self.second: list[list[Vec]] = []
        for k in range(nb):
            r = rot[k]
            cm = _add(pos[k], _matvec(r, com[k]))
            ri = _matmul(r, inertia[k])
            i0 = [[_dot(ri[a], r[b]) if b >= a else None for b in range(3)] for a in range(3)]
            m = mass[k]
            sq = _dot(cm, cm)
            full: list[Vec] = [[0.0] * 3 for _ in range(3)]
            for a in range(3):
                for b in range(a, 3):
                    value = i0[a][b] + m * ((sq if a == b else 0.0) - cm[a] * cm[b])
                    full[a][b] = full[b][a] = value
            self.first.append(_scale(cm, m))
            self.second.append(full)
        self.parent = parent
        self.total_mass = float(model.total_mass)
        self.com0 = com[0]
        # composite (subtree) mass, first moment and inertia about O
        self.c_mass = list(mass)
        self.c_first = [list(h) for h in self.first]
        self.c_second = [[list(row) for row in s] for s in self.second]
        for k in range(nb - 1, 0, -1):
            p = parent[k]
            self.c_mass[p] += self.c_mass[k]
            self.c_first[p] = _add(self.c_first[p], self.c_first[k])
            self.c_second[p] = [_add(self.c_second[p][a], self.c_second[k][a]) for a in range(3)]

    def mass_matrix(self) -> list[list[Scalar]]:
        """A = the [omega0, q] block of H+ (1991 eq. 15), (3 + N) x (3 + N), by composite rigid bodies."""
        nb = len(self.parent)
        n = nb - 1
        big_m = self.total_mass
        h0 = self.c_first[0]
        size = 3 + n
        a: list[list[Scalar]] = [[0.0] * size for _ in range(size)]
        ic0 = self.c_second[0]
        for r in range(3):
            for c in range(r, 3):
                a[r][c] = ic0[r][c] - ((_dot(h0, h0) if r == c else 0.0) - h0[r] * h0[c]) / big_m
        f_ang: list[Vec] = [[0.0] * 3] * nb
        f_lin: list[Vec] = [[0.0] * 3] * nb
        for k in range(1, nb):  # F_k = I^c_k S_k: momentum at O of a unit rate of joint k
            u, w = self.axis[k], self.moment[k]
            hk = self.c_first[k]
            f_ang[k] = _add(_sym_mv(self.c_second[k], u), _cross(hk, w))
            f_lin[k] = _sub(_scale(w, self.c_mass[k]), _cross(hk, u))
            col = 3 + k - 1
            corr = _cross(h0, f_lin[k])
            for r in range(3):
                a[r][col] = f_ang[k][r] - corr[r] / big_m
        for k in range(1, nb):
            for i in range(1, k + 1):
                if i == k or self._ancestor(i, k):
                    value = _dot(self.axis[i], f_ang[k]) + _dot(self.moment[i], f_lin[k])
                else:
                    value = 0.0
                a[3 + i - 1][3 + k - 1] = value - _dot(f_lin[i], f_lin[k]) / big_m
        for r in range(size):
            for c in range(r):
                a[r][c] = a[c][r]
        return a

    def _ancestor(self, i: int, k: int) -> bool:
        j = self.parent[k]
        while j > 0:
            if j == i:
                return True
            j = self.parent[j]
        return False

    def bias(
        self, omega0: Vec, qdot: Sequence[Scalar], tau: Sequence[Scalar] | None, force: Vec | None, torque: Vec | None
    ) -> list[Scalar]:
        """Rows [omega0, q] of C+ - Q (1991 eq. 19) at zddot0 = 0, by Newton-Euler at O (v_O = 0)."""
        nb = len(self.parent)
        zero = [0.0, 0.0, 0.0]
        w: list[Vec] = [omega0] + [zero] * (nb - 1)
        v: list[Vec] = [zero] * nb
        al: list[Vec] = [zero] * nb  # spatial acceleration [alpha; beta] at O, zddot0 = 0
        be: list[Vec] = [zero] * nb
        for k in range(1, nb):
            p = self.parent[k]
            su, sw = _scale(self.axis[k], qdot[k - 1]), _scale(self.moment[k], qdot[k - 1])
            w[k] = _add(w[p], su)
            v[k] = _add(v[p], sw)
            al[k] = _add(al[p], _cross(w[k], su))
            be[k] = _add(be[p], _add(_cross(w[k], sw), _cross(v[k], su)))
        n_f: list[Vec] = []
        f_f: list[Vec] = []
        for k in range(nb):  # f_k = I_k a_k + V_k x* I_k V_k
            m, h, ib = self.mass[k], self.first[k], self.second[k]
            ang = _add(_sym_mv(ib, w[k]), _cross(h, v[k]))
            lin = _sub(_scale(v[k], m), _cross(h, w[k]))
            n_k = _add(_add(_sym_mv(ib, al[k]), _cross(h, be[k])), _add(_cross(w[k], ang), _cross(v[k], lin)))
            f_k = _add(_sub(_scale(be[k], m), _cross(h, al[k])), _cross(w[k], lin))
            n_f.append(n_k)
            f_f.append(f_k)
        if force is not None and torque is not None:  # thrusters: force at the spacecraft CM, torque
            n_f[0] = _sub(n_f[0], _add(torque, _cross(self.com0, force)))
            f_f[0] = _sub(f_f[0], force)
        for k in range(nb - 1, 0, -1):
            p = self.parent[k]
            n_f[p] = _add(n_f[p], n_f[k])
            f_f[p] = _add(f_f[p], f_f[k])
        delta = _scale(f_f[0], -1.0 / self.total_mass)  # uniform acceleration that zeroes the base force
        out = _add(n_f[0], _cross(self.c_first[0], delta))
        for k in range(1, nb):
            row = _dot(self.axis[k], _add(n_f[k], _cross(self.c_first[k], delta))) + _dot(
                self.moment[k], _add(f_f[k], _scale(delta, self.c_mass[k]))
            )
            if tau is not None:
                row = row - tau[k - 1]
            out.append(row)
        return out


def _cholesky_solve(a: list[list[Scalar]], b: list[Scalar]) -> list[Scalar]:
    """x with a x = b, a symmetric positive definite (straight-line Cholesky, no pivoting)."""
    n = len(b)
    low: list[list[Scalar]] = [[0.0] * n for _ in range(n)]
    inv: list[Scalar] = [0.0] * n
    for j in range(n):
        d = a[j][j]
        for k in range(j):
            d = d - low[j][k] * low[j][k]
        low[j][j] = _sqrt(d)
        inv[j] = 1.0 / low[j][j]
        for i in range(j + 1, n):
            s = a[i][j]
            for k in range(j):
                s = s - low[i][k] * low[j][k]
            low[i][j] = s * inv[j]
    y = list(b)
    for i in range(n):
        s = y[i]
        for k in range(i):
            s = s - low[i][k] * y[k]
        y[i] = s * inv[i]
    for i in reversed(range(n)):
        s = y[i]
        for k in range(i + 1, n):
            s = s - low[k][i] * y[k]
        y[i] = s * inv[i]
    return y


def _quat_rate_and_rotation(quat: Vec, omega0: Vec) -> tuple[Vec, list[Vec]]:
    """Normalised quaternion [x, y, z, w] -> (dq/dt = 1/2 q ⊗ [omega0, 0], T0)."""
    norm = _sqrt(quat[0] * quat[0] + quat[1] * quat[1] + quat[2] * quat[2] + quat[3] * quat[3])
    x, y, z, w = (c / norm for c in quat)
    vec = [x, y, z]
    cr = _cross(vec, omega0)
    rate = [0.5 * (w * omega0[i] + cr[i]) for i in range(3)] + [-0.5 * _dot(vec, omega0)]
    t0 = [
        [1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - z * w), 2.0 * (x * z + y * w)],
        [2.0 * (x * y + z * w), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - x * w)],
        [2.0 * (x * z - y * w), 2.0 * (y * z + x * w), 1.0 - 2.0 * (x * x + y * y)],
    ]
    return rate, t0


def state_derivative(model: Model, x: Sequence[Scalar], sin: Sequence[Scalar], cos: Sequence[Scalar], u: Sequence[Scalar]) -> list[Scalar]:
    """d/dt of the flat state x = [r_cm, v_cm, quat, omega0, q, qdot] under u = [tau, f_S, n_S] (scalar code).

    ``sin``/``cos`` are those of q. The same equations as ``simulate._derivative`` with
    :func:`freeflyer.forward_dynamics` (no external wrenches).
    """
    n = model.n_joints
    omega0 = list(x[10:13])
    qdot = list(x[13 + n : 13 + 2 * n])
    tau, force, torque = list(u[0:n]), list(u[n : n + 3]), list(u[n + 3 : n + 6])
    tree = _Tree(model, sin, cos)
    rhs = [-r for r in tree.bias(omega0, qdot, tau, force, torque)]
    acc = _cholesky_solve(tree.mass_matrix(), rhs)
    dquat, t0 = _quat_rate_and_rotation(list(x[6:10]), omega0)
    r_dd = _scale(_matvec(t0, force), 1.0 / tree.total_mass)
    return list(x[3:6]) + r_dd + dquat + acc[0:3] + qdot + acc[3:]


# ----------------------------------------------------------------- tracing and code generation
_SINCOS = """\
qa{j} = {src}
kk{j} = np.rint(qa{j} * INV_STEP)
xr{j} = (qa{j} - kk{j} * STEP_HI) - kk{j} * STEP_LO
zz{j} = xr{j} * xr{j}
sr{j} = xr{j} + xr{j} * (zz{j} * (((zz{j} * (-1.0 / 5040.0)) + 1.0 / 120.0) * zz{j} - 1.0 / 6.0))
cr{j} = 1.0 + zz{j} * ((((zz{j} * (-1.0 / 720.0)) + 1.0 / 24.0) * zz{j}) - 0.5)
tt{j} = np.int64(kk{j}) & 127
st{j} = SIN[tt{j}]
ct{j} = COS[tt{j}]
sn{j} = st{j} * cr{j} + ct{j} * sr{j}
cs{j} = ct{j} * cr{j} - st{j} * sr{j}"""

_EXPR = {
    "add": "{A} + {B}",
    "sub": "{A} - {B}",
    "mul": "{A} * {B}",
    "div": "{A} / {B}",
    "addk": "{A} + {K}",
    "mulk": "{A} * {K}",
    "axpy": "{A} + {B} * {K}",
    "recip": "1.0 / {A}",
    "sqrt": "np.sqrt({A})",
}


def _kernel_source(
    name: str, n_joints: int, out_row: int, trace: Callable[[_batch.Tape, list[Any], list[Any]], tuple[list[Any], list[Any]]]
) -> tuple[str, int]:
    """Straight-line numba source ``name(Z, count)`` looping over lanes i in [0, count).

    ``Z`` is one flat block of rows of ``LANES`` values (row r, lane i at r * LANES + i): the
    state rows first (q in rows 13..13 + N), then whatever the trace reads, outputs from row
    ``out_row`` on. One array with constant row offsets lets LLVM prove that the stores of one
    lane never feed the loads of another, so it vectorises the loop across lanes.
    ``trace(tape, sin, cos)`` returns (input sources, outputs): input Syms are created in the
    order of the returned source strings; sin/cos of q_j are computed in the loop from row
    13 + j with the table + series of ``_batch.sincos``.
    """
    tape = _batch.Tape()
    sin = [tape.input() for _ in range(n_joints)]
    cos = [tape.input() for _ in range(n_joints)]
    sources, outputs = trace(tape, sin, cos)
    program = _batch.Program(tape, [o if isinstance(o, _batch.Sym) else tape.const(float(o)) for o in outputs], name=name)
    body: list[str] = []
    used_angles: set[int] = set()
    input_lines: list[str] = []
    for r, (kind, a, _b, _k) in enumerate(program.ops):
        if kind != "in":
            continue
        if a < 2 * n_joints:
            j = a % n_joints
            if j not in used_angles:
                used_angles.add(j)
                input_lines += _SINCOS.format(j=j, src=f"Z[{(13 + j) * LANES} + i]").splitlines()
            input_lines.append(f"r{r} = {'sn' if a < n_joints else 'cs'}{j}")
        else:
            input_lines.append(f"r{r} = {sources[a - 2 * n_joints]}")
    body += input_lines
    for r, (kind, a, b, k) in enumerate(program.ops):
        if kind == "in":
            continue
        body.append(f"r{r} = " + _EXPR[kind].format(A=f"r{a}", B=f"r{b}", K=repr(k)))
    for j, (kind, value) in enumerate(program.outputs):
        body.append(f"Z[{(out_row + j) * LANES} + i] = {f'r{int(value)}' if kind == 'reg' else repr(value)}")
    lines = [f"def {name}(Z, count):", "    for i in range(count):"] + ["        " + line for line in body]
    return "\n".join(lines) + "\n", program.n_ops


def _trace_derivative(model: Model) -> Callable[[_batch.Tape, list[Any], list[Any]], tuple[list[Any], list[Any]]]:
    n = model.n_joints
    size = 13 + 2 * n

    def trace(tape: _batch.Tape, sin: list[Any], cos: list[Any]) -> tuple[list[Any], list[Any]]:
        rows = [r for r in range(size) if not 13 <= r < 13 + n]  # q enters through sin and cos only
        sources = [f"Z[{r * LANES} + i]" for r in rows] + [f"Z[{(size + r) * LANES} + i]" for r in range(n + 6)]
        xs: list[Any] = [None] * size
        for r in rows:
            xs[r] = tape.input()
        us = [tape.input() for _ in range(n + 6)]
        return sources, state_derivative(model, xs, sin, cos, us)

    return trace


def _trace_mass_matrix(model: Model) -> Callable[[_batch.Tape, list[Any], list[Any]], tuple[list[Any], list[Any]]]:
    def trace(tape: _batch.Tape, sin: list[Any], cos: list[Any]) -> tuple[list[Any], list[Any]]:
        a = _Tree(model, sin, cos).mass_matrix()
        return [], [a[r][c] for r in range(len(a)) for c in range(r, len(a))]

    return trace


def _trace_bias(model: Model) -> Callable[[_batch.Tape, list[Any], list[Any]], tuple[list[Any], list[Any]]]:
    n = model.n_joints

    def trace(tape: _batch.Tape, sin: list[Any], cos: list[Any]) -> tuple[list[Any], list[Any]]:
        rows = [10, 11, 12, *range(13 + n, 13 + 2 * n)]
        sources = [f"Z[{r * LANES} + i]" for r in rows]
        inputs = [tape.input() for _ in rows]
        return sources, _Tree(model, sin, cos).bias(inputs[0:3], inputs[3:], None, None, None)

    return trace


_DRIVERS = """
S = {S}
N = {N}
NU = {NU}
NH = {NH}
SL = S * LANES
UO = S * LANES  # offset of the actuation rows in a block
DO = (S + NU) * LANES  # offset of the derivative rows in a block
ZL = (2 * S + NU) * LANES  # block size
HL = (S + NH) * LANES  # block size for H+ and C+


@nb.njit(cache=True, nogil=True, error_model="numpy")
def rk4_block(Y, Z, K, dt, L):
    # one RK4 step of lanes 0..L-1 of Y (S rows of LANES, flat) in place, the actuation held in
    # the U rows of the block Z; K: 3 S LANES workspace
    h = 0.5 * dt
    for r in range(S):
        o = r * LANES
        for i in range(o, o + L):
            Z[i] = Y[i]
    deriv(Z, L)
    for r in range(S):
        o = r * LANES
        for i in range(o, o + L):
            K[i] = Z[DO + i]
            Z[i] = Y[i] + h * Z[DO + i]
    deriv(Z, L)
    for r in range(S):
        o = r * LANES
        for i in range(o, o + L):
            K[SL + i] = Z[DO + i]
            Z[i] = Y[i] + h * Z[DO + i]
    deriv(Z, L)
    for r in range(S):
        o = r * LANES
        for i in range(o, o + L):
            K[2 * SL + i] = Z[DO + i]
            Z[i] = Y[i] + dt * Z[DO + i]
    deriv(Z, L)
    c = dt / 6.0
    for r in range(S):
        o = r * LANES
        for i in range(o, o + L):
            Y[i] = Y[i] + c * (K[i] + 2.0 * K[SL + i] + 2.0 * K[2 * SL + i] + Z[DO + i])
    for i in range(L):
        a = Y[6 * LANES + i]
        b = Y[7 * LANES + i]
        e = Y[8 * LANES + i]
        d = Y[9 * LANES + i]
        norm = np.sqrt(a * a + b * b + e * e + d * d)
        for r in range(6, 10):
            Y[r * LANES + i] = Y[r * LANES + i] / norm


@nb.njit(cache=True, nogil=True, error_model="numpy")
def steps_single(x, u, dt, nsteps):
    # nsteps RK4 steps of one state x (S,) in place under the held actuation u (NU,)
    Y = np.zeros(SL)
    Z = np.zeros(ZL)
    K = np.empty(3 * SL)
    for r in range(S):
        Y[r * LANES] = x[r]
    for r in range(NU):
        Z[UO + r * LANES] = u[r]
    for _ in range(nsteps):
        rk4_block(Y, Z, K, dt, 1)
    for r in range(S):
        x[r] = Y[r * LANES]


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _control(Y, Z, sat, lo, cnt, sample, kp, kd, qref, vref, ff, lim):
    k = min(sample, ff.shape[0] - 1)
    width = ff.shape[2]  # N (joint torques only) or NU; the columns beyond it are zero
    for i in range(cnt):
        b = lo + i
        flag = False
        for j in range(NU):
            val = ff[k, b, j] if j < width else 0.0
            if j < N:
                val = val + kp[b, j] * (qref[b, j] - Y[(13 + j) * LANES + i]) + kd[b, j] * (vref[b, j] - Y[(13 + N + j) * LANES + i])
            if val > lim[j]:
                val = lim[j]
                flag = True
            elif val < -lim[j]:
                val = -lim[j]
                flag = True
            Z[UO + j * LANES + i] = val
        sat[i] = flag


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _record(XS, US, SAT, row, Y, Z, sat, lo, cnt):
    for i in range(cnt):
        for r in range(S):
            XS[row, lo + i, r] = Y[r * LANES + i]
        for r in range(NU):
            US[row, lo + i, r] = Z[UO + r * LANES + i]
        SAT[row, lo + i] = sat[i]


@nb.njit(cache=True, nogil=True, error_model="numpy")
def rollout_blocks(b0, b1, X0, dt, steps, hold, stride, kp, kd, qref, vref, ff, lim, XS, US, SAT):
    # blocks b0..b1-1 of LANES rows of X0 (B, S): fixed-step RK4 with the joint PD
    # u = ff + kp (qref - q) + kd (vref - qdot) sampled every hold steps (ff[k] at sample k, the
    # last one held), clipped to +-lim; states, actuations and saturation flags recorded at
    # step 0, every stride steps and the last step
    B = X0.shape[0]
    Y = np.zeros(SL)
    Z = np.zeros(ZL)
    K = np.empty(3 * SL)
    sat = np.zeros(LANES, dtype=np.bool_)
    for blk in range(b0, b1):
        lo = blk * LANES
        cnt = min(LANES, B - lo)
        for i in range(cnt):
            for r in range(S):
                Y[r * LANES + i] = X0[lo + i, r]
        _control(Y, Z, sat, lo, cnt, 0, kp, kd, qref, vref, ff, lim)
        _record(XS, US, SAT, 0, Y, Z, sat, lo, cnt)
        row = 1
        for step in range(1, steps + 1):
            rk4_block(Y, Z, K, dt, cnt)
            if step % hold == 0 and step < steps:
                _control(Y, Z, sat, lo, cnt, step // hold, kp, kd, qref, vref, ff, lim)
            if step % stride == 0 or step == steps:
                _record(XS, US, SAT, row, Y, Z, sat, lo, cnt)
                row += 1


@nb.njit(cache=True, nogil=True, error_model="numpy")
def deriv_blocks(b0, b1, X, UB, OUT):
    # state derivatives of the rows of X (C, S) under UB (C, NU) into OUT (C, S), blocks b0..b1-1
    C = X.shape[0]
    Z = np.zeros(ZL)
    for blk in range(b0, b1):
        lo = blk * LANES
        cnt = min(LANES, C - lo)
        for i in range(cnt):
            for r in range(S):
                Z[r * LANES + i] = X[lo + i, r]
            for r in range(NU):
                Z[UO + r * LANES + i] = UB[lo + i, r]
        deriv(Z, cnt)
        for i in range(cnt):
            for r in range(S):
                OUT[lo + i, r] = Z[DO + r * LANES + i]


@nb.njit(cache=True, nogil=True, error_model="numpy")
def hplus_blocks(b0, b1, X, OUT):
    # upper triangles (row by row) of the [omega0, q] block of H+ at the q of the states X (C, S)
    C = X.shape[0]
    Z = np.zeros(HL)
    for blk in range(b0, b1):
        lo = blk * LANES
        cnt = min(LANES, C - lo)
        for i in range(cnt):
            for r in range(S):
                Z[r * LANES + i] = X[lo + i, r]
        hplus(Z, cnt)
        for i in range(cnt):
            for r in range(NH):
                OUT[lo + i, r] = Z[SL + r * LANES + i]


@nb.njit(cache=True, nogil=True, error_model="numpy")
def cplus_blocks(b0, b1, X, OUT):
    # rows [omega0, q] of C+ at the states X (C, S)
    C = X.shape[0]
    Z = np.zeros(HL)
    for blk in range(b0, b1):
        lo = blk * LANES
        cnt = min(LANES, C - lo)
        for i in range(cnt):
            for r in range(S):
                Z[r * LANES + i] = X[lo + i, r]
        cplus(Z, cnt)
        for i in range(cnt):
            for r in range(3 + N):
                OUT[lo + i, r] = Z[SL + r * LANES + i]
"""


def _cache_dir() -> Path:
    base = os.environ.get("FREEFLYER_CACHE_DIR") or os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    path = Path(base) / "freeflyer" / "compiled"
    try:
        path.mkdir(parents=True, exist_ok=True)
        probe = path / ".probe"
        probe.write_text("", encoding="utf-8")
        probe.unlink()
    except OSError:
        path = Path(tempfile.gettempdir()) / f"freeflyer-compiled-{os.getuid() if hasattr(os, 'getuid') else 'user'}"
        path.mkdir(parents=True, exist_ok=True)
    return path


def model_source(model: Model) -> str:
    """The generated Python/numba source of ``model``'s kernels (a pure function of the model's numbers)."""
    n = model.n_joints
    parts = [
        '"""Generated by freeflyer.mechanics._compiled for one model; do not edit."""',
        "import numba as nb",
        "import numpy as np",
        "from freeflyer.mechanics._batch import _COS as COS, _SIN as SIN, _STEP_HI as STEP_HI, _STEP_LO as STEP_LO",
        "INV_STEP = 64 / np.pi",
        f"LANES = {LANES}",
        "",
    ]
    counts = {}
    size = 13 + 2 * n
    for name, out_row, trace in (
        ("deriv", size + n + 6, _trace_derivative(model)),
        ("hplus", size, _trace_mass_matrix(model)),
        ("cplus", size, _trace_bias(model)),
    ):
        src, count = _kernel_source(name, n, out_row, trace)
        counts[name] = count
        parts.append('@nb.njit(cache=True, error_model="numpy")')
        parts.append(src)
    parts.append(f"N_OPS = {counts!r}")
    parts.append(_DRIVERS.format(S=13 + 2 * n, N=n, NU=n + 6, NH=(3 + n) * (4 + n) // 2))
    return "\n".join(parts)


_POOL: ThreadPoolExecutor | None = None
_POOL_LOCK = threading.Lock()


def threads() -> int:
    """Worker threads for batched calls: ``FREEFLYER_THREADS``, else ``NUMBA_NUM_THREADS``, else the CPU count."""
    value = os.environ.get("FREEFLYER_THREADS") or os.environ.get("NUMBA_NUM_THREADS")
    return max(1, int(value)) if value else max(1, os.cpu_count() or 1)


def _parallel(run: Callable[[int, int], Any], n_blocks: int, n_threads: int | None = None) -> None:
    """run(b0, b1) over contiguous ranges of blocks on a thread pool (the kernels release the GIL)."""
    global _POOL
    workers = min(n_threads or threads(), n_blocks)
    if workers <= 1:
        run(0, n_blocks)
        return
    with _POOL_LOCK:
        if _POOL is None or _POOL._max_workers < workers:
            _POOL = ThreadPoolExecutor(max_workers=max(workers, threads()), thread_name_prefix="freeflyer")
        pool = _POOL
    bounds = np.linspace(0, n_blocks, workers + 1).round().astype(int)
    futures = [pool.submit(run, int(a), int(b)) for a, b in itertools.pairwise(bounds) if b > a]
    for future in futures:
        future.result()


class Kernels:
    """The compiled kernels of one model (see :func:`kernels`); flat arrays in, no input checks."""

    def __init__(self, model: Model) -> None:
        t0 = time.perf_counter()
        source = model_source(model)
        self.trace_seconds = time.perf_counter() - t0
        digest = hashlib.sha256(source.encode()).hexdigest()[:20]
        name = f"ff_kernels_{digest}"
        path = _cache_dir() / f"{name}.py"
        if not path.exists() or path.read_text(encoding="utf-8") != source:
            tmp = path.with_suffix(f".{os.getpid()}.tmp")
            tmp.write_text(source, encoding="utf-8")
            os.replace(tmp, path)
        spec = importlib.util.spec_from_file_location(name, path)
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
        self.module = module
        self.path = path
        self.n_ops: dict[str, int] = module.N_OPS
        self.n_joints = model.n_joints
        self.size = 13 + 2 * model.n_joints
        self.compile_seconds: dict[str, float] = {}
        self._lock = threading.Lock()

    def warm(self, *which: str) -> dict[str, float]:
        """Compile (or load from numba's cache) the named drivers now; returns the seconds each took so far.

        Names: ``steps_single``, ``rollout_blocks``, ``deriv_blocks``, ``hplus_blocks``, ``cplus_blocks``.
        """
        n, s = self.n_joints, self.size
        x = np.zeros((1, s))
        x[:, 9] = 1.0
        u = np.zeros((1, n + 6))
        zeros = np.zeros((1, n))
        calls: dict[str, Callable[[], Any]] = {
            "steps_single": lambda: self.steps(x[0].copy(), u[0].copy(), 1e-3, 1),
            "rollout_blocks": lambda: self.rollout_pd(x, 1e-3, 1, 1, 1, zeros, zeros, zeros, None, None, None),
            "deriv_blocks": lambda: self.derivative(x, u),
            "hplus_blocks": lambda: self.mass_matrix(x),
            "cplus_blocks": lambda: self.bias(x),
        }
        for key in which or tuple(calls):
            if key not in self.compile_seconds:
                with self._lock:
                    if key not in self.compile_seconds:
                        t0 = time.perf_counter()
                        calls[key]()
                        self.compile_seconds[key] = time.perf_counter() - t0
        return dict(self.compile_seconds)

    def _blocks(self, size: int) -> int:
        return (size + LANES - 1) // LANES

    def derivative(self, x: np.ndarray, u: np.ndarray, n_threads: int | None = None) -> np.ndarray:
        """State derivatives (C, S) of states x (C, S) under actuations u (C, N + 6) = [tau, f_S, n_S]."""
        x = np.ascontiguousarray(x, dtype=float)
        u = np.ascontiguousarray(u, dtype=float)
        out = np.empty_like(x)
        _parallel(lambda a, b: self.module.deriv_blocks(a, b, x, u, out), self._blocks(x.shape[0]), n_threads)
        return out

    def mass_matrix(self, x: np.ndarray, n_threads: int | None = None) -> np.ndarray:
        """The [omega0, q] block of H+ (C, 3 + N, 3 + N) at the q of states x (C, S)."""
        n = self.n_joints
        x = np.ascontiguousarray(x, dtype=float)
        tri = np.empty((x.shape[0], (3 + n) * (4 + n) // 2))
        _parallel(lambda a, b: self.module.hplus_blocks(a, b, x, tri), self._blocks(x.shape[0]), n_threads)
        out = np.empty((x.shape[0], 3 + n, 3 + n))
        rows, cols = np.triu_indices(3 + n)
        out[:, rows, cols] = tri
        out[:, cols, rows] = tri
        return out

    def bias(self, x: np.ndarray, n_threads: int | None = None) -> np.ndarray:
        """Rows [omega0, q] of C+ (C, 3 + N) at states x (C, S)."""
        x = np.ascontiguousarray(x, dtype=float)
        out = np.empty((x.shape[0], 3 + self.n_joints))
        _parallel(lambda a, b: self.module.cplus_blocks(a, b, x, out), self._blocks(x.shape[0]), n_threads)
        return out

    def steps(self, x: np.ndarray, u: np.ndarray, dt: float, nsteps: int = 1) -> None:
        """Advance one state x (S,) (C-contiguous float array) by ``nsteps`` RK4 steps in place, u (N + 6,) held."""
        self.module.steps_single(x, u, dt, nsteps)

    def simulate(
        self, x0: np.ndarray, dt: float, steps: int, controller: Callable[[float, np.ndarray], Any], hold: int = 1, stride: int = 1
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """One fixed-step RK4 trajectory with a Python controller sampled every ``hold`` steps (zero-order hold).

        ``controller(t, x)`` gets the flat state x (S,) = [r_cm, v_cm, quat, omega0, q, qdot] (a
        read-only view; copy what you keep) and returns joint torques (N,) or [tau, f_S, n_S]
        (N + 6,). Between samples the RK4 steps run compiled, without Python. States are kept
        every ``stride`` steps and at the end. Returns (t (T,), x (T, S), u (T, N + 6)). No input
        checks: the low-level loop under ``freeflyer.simulate``'s validation, for hot loops.
        """
        x = np.array(x0, dtype=float, order="C")
        u = np.zeros(self.n_joints + 6)
        run = self.module.steps_single
        view = x.view()
        view.flags.writeable = False

        def sample(t: float) -> None:
            raw = np.asarray(controller(t, view), dtype=float)
            u[: raw.shape[0]] = raw

        sample(0.0)
        times, states, acts = [0.0], [x.copy()], [u.copy()]
        i = 0
        while i < steps:
            todo = min(hold - i % hold, stride - i % stride, steps - i)
            run(x, u, dt, todo)
            i += todo
            if i % hold == 0 and i < steps:
                sample(i * dt)
            if i % stride == 0 or i == steps:
                times.append(i * dt)
                states.append(x.copy())
                acts.append(u.copy())
        return np.asarray(times), np.stack(states), np.stack(acts)

    def steps_batch(self, x: np.ndarray, u: np.ndarray, dt: float, nsteps: int = 1, n_threads: int | None = None) -> None:
        """Advance states x (B, S) in place by ``nsteps`` RK4 steps, u (B, N + 6) held (blocks on a thread pool)."""
        zeros = np.zeros((x.shape[0], self.n_joints))
        xs, _, _ = self.rollout_pd(x, dt, nsteps, nsteps, nsteps, zeros, zeros, zeros, None, u[None], None, n_threads)
        x[...] = xs[-1]

    def rollout_pd(
        self,
        x0: np.ndarray,
        dt: float,
        steps: int,
        hold: int,
        stride: int,
        kp: np.ndarray,
        kd: np.ndarray,
        q_ref: np.ndarray,
        qdot_ref: np.ndarray | None,
        feedforward: np.ndarray | None,
        limit: np.ndarray | None,
        n_threads: int | None = None,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Batched fixed-step RK4 with a joint PD controller, all compiled.

        x0 (B, S); kp, kd, q_ref, qdot_ref (B, N); feedforward (K, B, N + 6) actuation (or (K, B, N)
        joint torques) at sample k (the last held after K samples) or None; limit (N + 6,) symmetric saturation (inf for
        none) or None. Returns states (T, B, S), actuations (T, B, N + 6), saturated (T, B).
        ``n_threads`` threads each run a contiguous range of blocks of ``LANES`` trajectories.
        """
        n = self.n_joints
        x0 = np.ascontiguousarray(x0, dtype=float)
        batch = x0.shape[0]
        rows = 1 + sum(1 for i in range(1, steps + 1) if i % stride == 0 or i == steps)
        vref = np.zeros((batch, n)) if qdot_ref is None else np.ascontiguousarray(np.broadcast_to(qdot_ref, (batch, n)), dtype=float)
        ff = np.zeros((1, batch, n + 6)) if feedforward is None else np.ascontiguousarray(feedforward, dtype=float)
        lim = np.full(n + 6, np.inf) if limit is None else np.ascontiguousarray(limit, dtype=float)
        xs = np.empty((rows, batch, self.size))
        us = np.empty((rows, batch, n + 6))
        sat = np.empty((rows, batch), dtype=bool)
        kp_, kd_, qr_ = (np.ascontiguousarray(np.broadcast_to(a, (batch, n)), dtype=float) for a in (kp, kd, q_ref))
        run = self.module.rollout_blocks

        def part(a: int, b: int) -> None:
            run(a, b, x0, float(dt), int(steps), int(hold), int(stride), kp_, kd_, qr_, vref, ff, lim, xs, us, sat)

        _parallel(part, self._blocks(batch), n_threads)
        return xs, us, sat


def rollout_rows(
    model: Model, x0: np.ndarray, dt: float, steps: int, hold: int, stride: int, controller: Any, limits: Any
) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] | None:
    """A whole batched rollout compiled: ``controller`` None or a :class:`freeflyer.pd.JointPD`.

    Returns the output times (T,), the states (T, B, S) and the actuation (tau (T, B, N),
    f_S (T, B, 3), n_S (T, B, 3), saturated (T, B)), or None when this controller cannot run compiled (a
    feed-forward sampled at another period than the controller), or when an angle leaves the
    range of the sin/cos table (|q| > 1e5 rad): the caller then steps in Python.
    """
    n = model.n_joints
    batch = x0.shape[0]
    lim = np.full(n + 6, np.inf)
    if limits is not None:
        limits.apply(np.zeros(n), np.zeros(3), np.zeros(3))  # validates the limits (same errors as the numpy path)
        for sl, value in (
            (slice(0, n), limits.joint_torque),
            (slice(n, n + 3), limits.spacecraft_force),
            (slice(n + 3, n + 6), limits.spacecraft_torque),
        ):
            if value is not None:
                lim[sl] = np.broadcast_to(np.asarray(value, dtype=float), lim[sl].shape)
    zeros = np.zeros((batch, n))
    if controller is None:
        gains: list[Any] = [zeros, zeros, zeros, zeros]
        feed = None
    else:
        gains = [controller.kp, controller.kd, controller.q_ref, controller.qdot_ref]
        feed = None
        if controller.feedforward is not None:
            ff = np.asarray(controller.feedforward, dtype=float)
            if ff.shape[0] > 1 and not math.isclose(float(controller.feedforward_period), hold * dt, rel_tol=1e-9):
                return None
            feed = np.ascontiguousarray(np.broadcast_to(ff[:, None, :] if ff.ndim == 2 else ff, (ff.shape[0], batch, n)))
    try:
        gains = [np.broadcast_to(np.asarray(g, dtype=float), (batch, n)) for g in gains]
    except ValueError:
        return None  # shapes the numpy path reports with its own error
    xs, us, sat = kernels(model).rollout_pd(x0, dt, steps, hold, stride, gains[0], gains[1], gains[2], gains[3], feed, lim)
    if not np.max(np.abs(xs[:, :, 13 : 13 + n]), initial=0.0) <= _batch._MAX_TABLE_ANGLE:
        return None
    times = np.array([0.0] + [i * dt for i in range(1, steps + 1) if i % stride == 0 or i == steps])
    return times, xs, (us[:, :, :n], us[:, :, n : n + 3], us[:, :, n + 3 :], sat)


def kernels(model: Model) -> Kernels:
    """The compiled kernels of ``model``, built on first use and kept as long as the model lives.

    Tracing and code generation take well under a second; numba compiles each driver on its
    first call (seconds; then loaded from numba's on-disk cache in later processes).
    """
    cache = _batch.program_cache(model)
    key = "compiled-dynamics"
    if key not in cache.programs:
        with cache.lock:
            if key not in cache.programs:
                cache.programs[key] = Kernels(model)
    return cache.programs[key]

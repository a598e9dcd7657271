"""A simulated trajectory: states against time, the actuation applied, and derived quantities.

Arrays are time first. Frames: r_cm, v_cm, momentum and end-effector positions
inertial; omega and the actuation in the spacecraft frame (see conventions).
"""

from __future__ import annotations

import csv
import json
import warnings
from dataclasses import asdict, dataclass, field, fields
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from ..core.conventions import attitude_matrix, euler321_from_matrix
from ..core.model import Model
from ..core.numbers import computed_states
from ..core.state import State
from ..mechanics.dynamics import dissipative_torque, passive_torque
from ..mechanics.kinematics import end_effector_positions, end_effector_rotations, point_positions
from ..mechanics.momentum import angular_momentum, kinetic_energy

__all__ = ["JointLimitEvent", "Trajectory"]

#: The arrays of a run with reaction wheels (None without): angle and speed relative to the spacecraft, motor torque
#: applied, and whether each wheel's torque or speed limit acted.
_WHEEL_ARRAYS = ("wheel_angle", "wheel_speed", "wheel_torque", "wheel_torque_saturated", "wheel_speed_saturated")

_ARRAYS = (
    "t",
    "q",
    "qdot",
    "omega",
    "attitude",
    "r_cm",
    "v_cm",
    "joint_torque",
    "spacecraft_force",
    "spacecraft_torque",
    "saturated",
    "dissipated_energy",
    *_WHEEL_ARRAYS,
)
#: Arrays a file may lack: written by a freefloat before them (``dissipated_energy``: see :meth:`Trajectory.load`), or
#: of a model without reaction wheels.
_OPTIONAL = ("dissipated_energy", *_WHEEL_ARRAYS)


@dataclass(frozen=True)
class JointLimitEvent:
    """A joint at one of its limits (``model.joint_lower`` / ``joint_upper``) during a simulation.

    ``kind == "impact"`` (hard stops on): the stop acted at ``t`` (``t_end == t``); ``value`` is
    the joint rate just before (rad/s), the rate after is ``-restitution * value``.
    ``kind == "violation"`` (stops off, ``joint_limits="flag"``): the joint was beyond ``limit``
    from the output time ``t`` to ``t_end`` (None: still beyond at the end); ``value`` is the
    furthest angle reached (rad). ``trajectory``: the index in a batched rollout (None: one run).
    """

    joint: str
    bound: str
    limit: float
    kind: str
    t: float
    t_end: float | None
    value: float
    trajectory: int | None = None


@dataclass(frozen=True, eq=False)
class Trajectory:
    """States at the output times ``t`` (T,), and the actuation held over each output instant.

    Batched rollouts (:func:`freefloat.rollout`) carry a batch axis after time:
    ``q`` is (T, B, N), ``r_cm`` (T, B, 3), and so on.

    ``status`` is ``"finished"``, ``"event"`` (a terminal event stopped it),
    ``"interrupted"`` (Ctrl-C) or ``"failed"`` (then ``message`` says why and
    the arrays hold what was computed before the failure). Derived quantities
    need ``model``. ``joint_limit_events``: the hard-stop impacts, or the limit
    violations when stops are off (:class:`JointLimitEvent`).

    ``dissipated_energy`` (T,) (T, B for a rollout), J: the energy the joints' viscous damping and Coulomb friction
    have dissipated since the start of the run, integrated with the state by the run's own integrator (the dissipated
    power sum_k qdot_k (d_k qdot_k + F_k tanh(qdot_k / v_s)) >= 0 over the joints is one more component of the
    integrated state: ``freefloat.core.state``), so it is exact to the integrator's accuracy at every output time,
    however seldom the run records. With it, kinetic energy + dissipated = initial kinetic energy + the work of the
    actuators (and of external wrenches), to that accuracy. Zeros for a model without damping and friction or a run
    with ``passive="ignore"``. None when unknown: a trajectory made without it, or a file of an older freefloat loaded
    without its model (:meth:`load`).

    Reaction wheels (a model with ``model.wheels``; None otherwise), each (T, W), ``model.wheels`` order:
    ``wheel_angle`` (rad) and ``wheel_speed`` (rad/s) relative to the spacecraft, ``wheel_torque`` the motor torque
    applied (N m, after the limits), ``wheel_torque_saturated`` (the command was beyond ``max_torque`` and was
    clipped) and ``wheel_speed_saturated`` (the wheel was at ``max_speed`` and the torque that would have spun it
    faster was not applied), per output. ``saturated`` is true where any actuator, wheels included, was limited.
    The momentum and kinetic energy include the wheels' spin.
    """

    t: np.ndarray
    q: np.ndarray
    qdot: np.ndarray
    omega: np.ndarray
    attitude: np.ndarray
    r_cm: np.ndarray
    v_cm: np.ndarray
    joint_torque: np.ndarray
    spacecraft_force: np.ndarray
    spacecraft_torque: np.ndarray
    saturated: np.ndarray
    status: str = "finished"
    message: str = ""
    model_name: str = ""
    model: Model | None = field(default=None, repr=False)
    joint_limit_events: tuple[JointLimitEvent, ...] = ()
    dissipated_energy: np.ndarray | None = None
    wheel_angle: np.ndarray | None = None
    wheel_speed: np.ndarray | None = None
    wheel_torque: np.ndarray | None = None
    wheel_torque_saturated: np.ndarray | None = None
    wheel_speed_saturated: np.ndarray | None = None

    @property
    def joint_limits_violated(self) -> bool:
        """True when a joint went beyond a limit (stops off); the times are in :attr:`joint_limit_events`."""
        return any(e.kind == "violation" for e in self.joint_limit_events)

    # ----------------------------------------------------------- derived
    def _need_model(self) -> Model:
        if self.model is None:
            raise ValueError("this trajectory has no model attached; load it with Trajectory.load(path, model=...)")
        return self.model

    @property
    def velocity(self) -> np.ndarray:
        """zdot0 = [v_cm, omega, qdot] (T, 6+N)."""
        return np.concatenate([self.v_cm, self.omega, self.qdot], axis=-1)

    @cached_property
    def angular_momentum(self) -> np.ndarray:
        """Angular momentum about the system CM, inertial frame (T, 3): of the bodies (rows [omega0] of H+ zdot0, 1992
        eq. 12). It does not include the spin of the joints' rotors (``model.joint_armature``): that model, as MuJoCo's
        and Pinocchio's armature, adds each rotor's inertia to its own joint and gives the spacecraft no reaction to it.
        The reaction wheels' spin is included (:func:`freefloat.mechanics.momentum.wheel_momentum`)."""
        with computed_states():
            return angular_momentum(self._need_model(), self.q, self.velocity, attitude=self.attitude, wheel_speed=self.wheel_speed)

    @cached_property
    def linear_momentum(self) -> np.ndarray:
        """M v_cm, inertial frame (T, 3)."""
        return self._need_model().total_mass * self.v_cm

    @cached_property
    def kinetic_energy(self) -> np.ndarray:
        """1/2 zdot0^T H+ zdot0 (T,), with the reaction wheels' spin."""
        with computed_states():
            return kinetic_energy(self._need_model(), self.q, self.velocity, wheel_speed=self.wheel_speed)

    @cached_property
    def passive_torque(self) -> np.ndarray:
        """The joints' passive torques at the output times (T, N) (T, B, N for a rollout): damping, friction and springs
        (:func:`freefloat.mechanics.passive_torque`; zeros for a model without, or a run with ``passive="ignore"``, which
        keeps the springs)."""
        return passive_torque(self._need_model(), self.qdot, self.q)

    @cached_property
    def end_effector_positions(self) -> np.ndarray:
        """End-effector positions in the inertial frame (T, E, 3): r_cm + T0 rho_E."""
        with computed_states():
            return self.r_cm[..., None, :] + end_effector_positions(self._need_model(), self.q, attitude=self.attitude)

    @cached_property
    def end_effector_rotations(self) -> np.ndarray:
        """End-effector frame orientations, body frame -> inertial frame (T, E, 3, 3): T0 R_E."""
        model = self._need_model()
        with computed_states():
            return np.einsum("...ij,...ejk->...eik", attitude_matrix(self.attitude), end_effector_rotations(model, self.q))

    @cached_property
    def spacecraft_position(self) -> np.ndarray:
        """Spacecraft CM in the inertial frame (T, 3)."""
        model = self._need_model()
        with computed_states():
            rho = point_positions(model, self.q, 0, model.com[0])
        return self.r_cm + np.einsum("...ij,...j->...i", attitude_matrix(self.attitude), rho)

    @cached_property
    def spacecraft_euler321(self) -> np.ndarray:
        """Spacecraft Euler 3-2-1 angles [roll, pitch, yaw] (T, 3), rad (1991 eq. 11)."""
        return euler321_from_matrix(attitude_matrix(self.attitude))

    # ----------------------------------------------------------- plot
    def plot(self, axes: Any = None) -> list[Any]:
        """Joint angles, spacecraft attitude and position, and actuation against time.

        ``axes``: four matplotlib Axes (or None: a new pyplot figure, which
        ``plt.show()`` and notebooks display). Returns the line artists.
        """
        from .trajectory_plots import plot_trajectory

        return plot_trajectory(self, axes)

    def plot_path(self, ax: Any = None, *, snapshots: int = 4) -> list[Any]:
        """End-effector and spacecraft CM paths (inertial) with the spacecraft body axes at ``snapshots`` + 1 times.

        3D axes for a spatial model (None: a new pyplot figure), the x-y plane for a planar one. Returns the artists.
        """
        from .trajectory_plots import plot_path

        return plot_path(self, ax, snapshots=snapshots)

    def animate(
        self, path: str | Path, *, fps: int = 20, max_frames: int = 120, dpi: int = 80, overwrite: bool = False, progress: Any = None
    ) -> Path:
        """Write an animation of the motion to ``path``: ``.gif`` (Pillow) or ``.mp4`` (ffmpeg); returns the path.

        At most ``max_frames`` frames (evenly spaced output samples) at ``fps``
        frames per second. Never overwrites an existing file unless ``overwrite=True``.
        ``progress``: as :func:`freefloat.simulate`'s, counting frames (a 120-frame GIF takes ~20 s).
        """
        from .trajectory_plots import animate_trajectory

        return animate_trajectory(self, path, fps=fps, max_frames=max_frames, dpi=dpi, overwrite=overwrite, progress=progress)

    # ----------------------------------------------------------- files
    def save(self, path: str | Path, *, overwrite: bool = False) -> Path:
        """Write ``.npz`` (all arrays and metadata) or ``.csv`` (one row per time). Never overwrites unless asked.

        The CSV has one header row of column names (``t``, ``q[shoulder]``, ... one per joint by name,
        ``omega[x]``, ..., ``attitude[w]``, ..., ``saturated``) that ``pandas.read_csv`` reads as is; its metadata
        (status, message, model name, array shapes) go to the sidecar ``PATH.json``
        (``trajectory.csv`` -> ``trajectory.csv.json``).
        """
        path = Path(path)
        if path.suffix not in (".npz", ".csv"):
            raise ValueError(f"{path}: unknown trajectory file type {path.suffix!r}; use .npz or .csv")
        sidecar = _sidecar(path)
        for target in (path, sidecar) if path.suffix == ".csv" else (path,):
            if target.exists() and not overwrite:
                raise FileExistsError(f"{target}: exists; freefloat does not overwrite files (pass overwrite=True or choose another name)")
        path.parent.mkdir(parents=True, exist_ok=True)
        meta: dict[str, Any] = {
            "status": self.status,
            "message": self.message,
            "model_name": self.model_name or (self.model.name if self.model else ""),
            "shapes": {name: list(np.shape(getattr(self, name))[1:]) for name in self._saved()},
            "joint_limit_events": [asdict(e) for e in self.joint_limit_events],
        }
        if path.suffix == ".npz":
            with path.open("wb") as fh:
                np.savez(fh, **{name: getattr(self, name) for name in self._saved()}, meta=json.dumps(meta))
        elif path.suffix == ".csv":
            header, columns = self._columns()
            sidecar.write_text(json.dumps({"freefloat_trajectory": meta, "columns": header}, indent=2) + "\n", encoding="utf-8")
            with path.open("w", newline="", encoding="utf-8") as fh:
                writer = csv.writer(fh)
                writer.writerow(header)
                writer.writerows(np.column_stack(columns).tolist())
        else:
            raise ValueError(f"{path}: unknown trajectory file type {path.suffix!r}; use .npz or .csv")
        return path

    def _saved(self) -> list[str]:
        """The arrays a file holds: all of them (the dissipated energy when known)."""
        return [name for name in _ARRAYS if getattr(self, name) is not None]

    def _columns(self) -> tuple[list[str], list[np.ndarray]]:
        """CSV column names and values: ``t``, ``q[joint]`` per joint (by name when the model is known), ``omega[x]``
        ... per component, ``attitude[x]`` ... ``attitude[w]``; a batched trajectory's columns ``q[b][joint]``."""
        header: list[str] = []
        columns: list[np.ndarray] = []
        joints = list(self.model.joint_names) if self.model is not None else None
        for name in self._saved():
            arr = np.asarray(getattr(self, name), dtype=float)
            columns.append(arr.reshape(arr.shape[0], int(np.prod(arr.shape[1:]))))  # a trajectory of no samples too
            if arr.ndim == 1:
                header.append(name)
                continue
            last = arr.shape[-1]
            wheels = [w.name for w in self.model.wheels] if self.model is not None else None
            if name in ("q", "qdot", "joint_torque") and joints is not None and len(joints) == last:
                labels = joints
            elif name in _WHEEL_ARRAYS and wheels is not None and len(wheels) == last:
                labels = wheels
            elif name == "attitude":
                labels = ["x", "y", "z", "w"]
            elif last == 3 and name != "q":
                labels = ["x", "y", "z"]
            else:
                labels = [str(i) for i in range(last)]
            batch = ["".join(f"[{i}]" for i in index) for index in np.ndindex(*arr.shape[1:-1])]
            header += [f"{name}{b}[{label}]" for b in batch for label in labels]
        return header, columns

    @classmethod
    def load(cls, path: str | Path, model: Model | None = None) -> Trajectory:
        """Read a trajectory written by :meth:`save`; attach ``model`` for the derived quantities.

        A file written by a freefloat before the dissipated energy was integrated with the state holds none: with the
        model attached, ``dissipated_energy`` is then the trapezoidal rule over the file's output times (an estimate,
        exact to O(h^2) of the output period h: a warning says so; zeros, exact, for a model without damping and
        friction); without it, None (a warning says so too).
        """
        path = Path(path)
        if path.suffix == ".npz":
            try:
                with np.load(path, allow_pickle=False) as data:
                    missing = [name for name in (*_ARRAYS, "meta") if name not in data.files and name not in _OPTIONAL]
                    if missing:
                        raise ValueError(f"{path}: not a freefloat trajectory file, missing {', '.join(missing)}")
                    arrays = {name: data[name] for name in _ARRAYS if name in data.files}
                    meta = json.loads(str(data["meta"]))
            except (ValueError, OSError, EOFError, KeyError, AttributeError) as exc:  # numpy's errors for a file that is no .npz
                if str(path) in str(exc):
                    raise
                raise ValueError(f"{path}: not a trajectory file written by Trajectory.save ({exc})") from None
        elif path.suffix == ".csv":
            arrays, meta = _read_csv(path)
        else:
            raise ValueError(f"{path}: unknown trajectory file type {path.suffix!r}; use .npz or .csv")
        if "dissipated_energy" not in arrays:
            arrays["dissipated_energy"] = _older_file_dissipation(path, model, arrays["t"], arrays["qdot"])
        return cls(
            **arrays,
            status=meta.get("status", "finished"),
            message=meta.get("message", ""),
            model_name=meta.get("model_name", ""),
            model=model,
            joint_limit_events=tuple(JointLimitEvent(**e) for e in meta.get("joint_limit_events", [])),
        )

    def state(self, index: int = -1) -> State:
        """The state at output ``index`` (default: the last one), e.g. to continue a simulation."""
        return State(
            q=self.q[index].copy(),
            qdot=self.qdot[index].copy(),
            omega=self.omega[index].copy(),
            attitude=self.attitude[index].copy(),
            r_cm=self.r_cm[index].copy(),
            v_cm=self.v_cm[index].copy(),
            wheel_speed=None if self.wheel_speed is None else self.wheel_speed[index].copy(),
        )

    def __len__(self) -> int:
        return int(self.t.shape[0])

    def equals(self, other: Trajectory, rtol: float = 0.0, atol: float = 0.0) -> bool:
        """Array-wise comparison (for round-trip tests; an unknown dissipated energy equals only another unknown one)."""
        return all(_same(getattr(self, f.name), getattr(other, f.name), rtol, atol) for f in fields(self) if f.name in _ARRAYS)


def _same(a: np.ndarray | None, b: np.ndarray | None, rtol: float, atol: float) -> bool:
    if a is None or b is None:
        return a is None and b is None
    return bool(np.allclose(a, b, rtol=rtol, atol=atol))


def _older_file_dissipation(path: Path, model: Model | None, t: np.ndarray, qdot: np.ndarray) -> np.ndarray | None:
    """The dissipated energy of a file that holds none (written by an older freefloat): the trapezoidal rule over its
    output times with the model's passive torques (zeros without damping and friction: exact), else None; said."""
    if model is not None and not model.has_passive:
        return np.zeros(qdot.shape[:-1])
    if model is None:
        warnings.warn(
            f"{path}: the file holds no dissipated energy (written by an older freefloat): dissipated_energy is None; "
            "load it with its model for an estimate (the trapezoidal rule over the output times)",
            UserWarning,
            stacklevel=3,
        )
        return None
    warnings.warn(
        f"{path}: the file holds no dissipated energy (written by an older freefloat): dissipated_energy is the trapezoidal "
        "rule over its output times, an estimate exact to O(h^2) of the output period h; simulate again for the "
        "integrated one",
        UserWarning,
        stacklevel=3,
    )
    power = -np.sum(dissipative_torque(model, qdot) * qdot, axis=-1)
    steps = 0.5 * (power[1:] + power[:-1]) * np.diff(t).reshape((-1,) + (1,) * (power.ndim - 1))
    return np.concatenate([np.zeros_like(power[:1]), np.cumsum(steps, axis=0)], axis=0)


def _sidecar(path: Path) -> Path:
    """The metadata file of a trajectory CSV: ``run.csv`` -> ``run.csv.json``."""
    return path.with_name(path.name + ".json")


def _read_csv(path: Path) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Arrays and metadata of a CSV written by :meth:`Trajectory.save` (errors name what is wrong)."""
    sidecar = _sidecar(path)
    meta: dict[str, Any] = {}
    if sidecar.is_file():
        try:
            meta = json.loads(sidecar.read_text(encoding="utf-8"))["freefloat_trajectory"]
        except (ValueError, KeyError, TypeError) as exc:
            raise ValueError(f"{sidecar}: not the metadata of a freefloat trajectory CSV ({exc})") from exc
    with path.open(encoding="utf-8") as fh:
        first = fh.readline()
        if first.startswith("#"):
            raise ValueError(
                f"{path}: a trajectory CSV of freefloat 0.1.0 (metadata in a comment line), which 0.2.0 does not read: "
                "simulate again and save (see CHANGELOG.md)"
            )
        header = next(csv.reader([first]), [])
        rows = [line for line in fh if line.strip()]
    table = np.loadtxt(rows, delimiter=",", ndmin=2) if rows else np.zeros((0, len(header)))
    if table.shape[1] != len(header):
        raise ValueError(f"{path}: {table.shape[1]} columns of data but {len(header)} column names")
    shapes = meta.get("shapes", {})
    arrays = {}
    for name in _ARRAYS:
        cols = [i for i, h in enumerate(header) if h == name or h.startswith(f"{name}[")]
        if not cols and name in _OPTIONAL:
            continue
        if not cols:
            raise ValueError(f"{path}: not a freefloat trajectory CSV: no column {name!r} (or {name}[...]); write it with Trajectory.save")
        shape = tuple(shapes.get(name, [] if header[cols[0]] == name else [len(cols)]))
        arrays[name] = table[:, cols].reshape((table.shape[0], *shape))
    for name in ("saturated", "wheel_torque_saturated", "wheel_speed_saturated"):
        if name in arrays:
            arrays[name] = arrays[name].astype(bool)
    return arrays, meta

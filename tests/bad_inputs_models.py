"""Bad-input cases of issue 40: models by relative, spaced, unicode and symlinked paths; rollouts; the CLI's warnings and --out."""

from __future__ import annotations

from pathlib import Path

import numpy as np

import freefloat as ff
from bad_case import Case, add_file, api, cli
from freefloat.core.errors import MemoryBudgetError, ModelError, ShapeError

CASES: list[Case] = []

_ROOT = Path(__file__).resolve().parents[1]
_CAPTURE = _ROOT / "examples" / "scenarios" / "papadopoulos1992_capture.toml"
_SCENARIO = _ROOT / "examples" / "scenarios" / "papadopoulos1992_joint_pd.toml"
_Q = np.radians([0.0, 90.0, 180.0, -90.0])
_WHEELED = [{"name": "rw", "axis": [0.0, 0.0, 1.0], "inertia": 0.1}]


def _model() -> ff.Model:
    return ff.load("papadopoulos1992")


def _load_through(files: Path, *chain: str) -> None:
    """``ff.load("link.xml")``, a symbolic link in the case's working directory to the first of ``chain``, each a link
    to the next but the last (removed again)."""
    links = [Path.cwd() / "link.xml", *(Path.cwd() / name for name in chain[:-1])]
    for link, target in zip(links, chain, strict=True):
        link.symlink_to(target)
    try:
        ff.load(links[0].name)
    finally:
        for link in links:
            link.unlink()


# model paths: relative paths that name nothing, a broken link, a folder, a path with spaces (quoted as given)
CASES += [
    api(
        "path-relative-missing", lambda f: ff.load("../files/nothere/arm.xml"), ModelError, r"^\.\./files/nothere/arm\.xml: file not found"
    ),
    api("path-dot-relative-missing", lambda f: ff.load("./arm.xml"), ModelError, r"^\./arm\.xml: file not found"),
    api("path-spaces-missing", lambda f: ff.load("my models/bras_é.xml"), ModelError, r"^my models/bras_é\.xml: file not found"),
    api("path-folder", lambda f: ff.load(f), ModelError, r"files: is not a file; give the path of a \.toml"),
    api("path-relative-folder", lambda f: ff.load("../files"), ModelError, r"^\.\./files: is not a file"),
    api(
        "path-broken-symlink",
        lambda f: _load_through(f, "nowhere/arm.xml"),
        ModelError,
        r"^link\.xml: is a symbolic link to /\S+/work/nowhere/arm\.xml, which does not exist",
    ),
    api(  # a chain of links: the file missing at its end is named (was: the first hop)
        "path-broken-symlink-chain",
        lambda f: _load_through(f, "hop.xml", "gone/arm.xml"),
        ModelError,
        r"^link\.xml: is a symbolic link to /\S+/work/gone/arm\.xml, which does not exist",
    ),
    api(
        "path-backslash-missing",
        lambda f: ff.load("models\\arm.urdf"),
        ModelError,
        r"^models\\arm\.urdf: file not found \(use / as the separator: a backslash is part of a file name here\)",
    ),
]
CASES += [
    cli(
        "cli-inspect-path-backslash-missing",
        "inspect models\\arm.urdf",
        r"^error: models\\arm\.urdf: no such model file; use / as the separator",
    ),
]

# a file name that is not UTF-8 (made on another system; Python's surrogate escapes): one line, for every source (was: a
# TypeError traceback of MuJoCo's from_xml_path for MJCF, "malformed URDF" for URDF)
_MJCF = (
    '<mujoco><worldbody><body name="bus"><freejoint/><inertial pos="0 0 0" mass="100" diaginertia="10 10 10"/>'
    '<body name="a" pos="1 0 0"><joint name="j" type="hinge" axis="0 0 1"/><inertial pos="0.5 0 0" mass="1" '
    'diaginertia="0.1 0.1 0.1"/></body></body></worldbody></mujoco>'
)
_MODELS = _ROOT / "examples" / "models"
_LATIN1 = {
    "xml": _MJCF,
    "urdf": (_MODELS / "six_dof_arm.urdf").read_text(),
    "toml": (_MODELS / "papadopoulos1992_two_arm.toml").read_text(),
}
for _ext, _text in _LATIN1.items():
    add_file(f"latin1/bras\udce9.{_ext}", _text)  # the byte 0xe9 (e-acute in Latin-1) in the name
CASES += [
    api(
        f"path-not-utf8-{ext}",
        lambda f, ext=ext: ff.load(f / "latin1" / f"bras\udce9.{ext}"),
        ModelError,
        rf"bras\\xe9\.{ext}: the file name is not valid UTF-8; rename the file",
    )
    for ext in ("xml", "urdf", "toml")
]
CASES += [
    cli(
        f"cli-{command}-path-not-utf8-{ext}",
        f"{command} {{files}}/latin1/bras\udce9.{ext}",
        rf"^error: \S+/latin1/bras\\xe9\.{ext}: the file name is not valid UTF-8; rename the file",
    )
    for command in ("inspect", "workspace")
    for ext in ("xml", "urdf")
]
CASES += [
    cli("cli-inspect-path-relative-missing", "inspect ../files/nothere.xml", r"^error: \.\./files/nothere\.xml: no such model file"),
    cli("cli-inspect-path-relative-folder", "inspect ../files", r"^error: \.\./files: is not a file"),
    cli("cli-workspace-path-relative-missing", "workspace ./nothere.urdf", r"^error: \./nothere\.urdf: no such model file"),
    cli("cli-specialise-path-relative-missing", "specialise ../nothere.toml", r"^error: \.\./nothere\.toml: no such model file"),
]

# a scenario's model by a relative path that names nothing (relative to the scenario's folder, quoted as written)
_SIM = _SCENARIO.read_text()
_CAP = _CAPTURE.read_text()
add_file("paths/sim-model-missing.toml", _SIM.replace('model = "papadopoulos1992"', 'model = "../nothere/arm.xml"'))
add_file("paths/sim-model-folder.toml", _SIM.replace('model = "papadopoulos1992"', 'model = "../paths"'))
add_file("paths/cap-model-missing.toml", _CAP.replace('model = "papadopoulos1992-one-arm"', 'model = "./arm.urdf"'))
CASES += [
    cli(
        "cli-simulate-path-model-relative-missing",
        "simulate {files}/paths/sim-model-missing.toml --out out",
        r"sim-model-missing\.toml: model: \.\./nothere/arm\.xml: no such model file",
    ),
    cli("cli-capture-path-model-dot-missing", "capture {files}/paths/cap-model-missing.toml", r"model: \./arm\.urdf: no such model file"),
    cli(  # a folder next to the scenario is named as a folder, not as a missing file
        "cli-simulate-path-model-relative-folder",
        "simulate {files}/paths/sim-model-folder.toml --out out",
        r"sim-model-folder\.toml: model: .*/\.\./paths: is not a file; give the path of a \.toml",
    ),
]

# initial.wheel_speed of a scenario (issue 40: [1e300] gave "cannot reshape array of size 0")
_WHEEL = '\n[[wheels]]\nname = "rw_z"\naxis = [0.0, 0.0, 1.0]\ninertia = 0.15\nmax_torque = 1.0\nmax_speed = 600.0\n'
for _id, _speed in (("huge", "[1e300]"), ("nan", "[nan]"), ("inf", "[inf]"), ("text", '["fast"]'), ("too-many", "[1.0, 2.0]")):
    add_file(f"wheels/speed-{_id}.toml", _SIM.replace("[initial]\n", f"[initial]\nwheel_speed = {_speed}\n", 1) + _WHEEL)
CASES += [
    cli(f"cli-simulate-wheel-speed-{id}", f"simulate {{files}}/wheels/speed-{id}.toml --out out", match)
    for id, match in (
        ("huge", r"initial: State\.wheel_speed: 1e\+300 is beyond 10000 \(rad/s\), which no reaction wheel turns at"),
        ("nan", r"initial\.wheel_speed: has NaN or infinite entries"),
        ("inf", r"initial\.wheel_speed: has NaN or infinite entries"),
        ("text", r"initial\.wheel_speed: expected numbers, got \['fast'\]"),
        ("too-many", r"initial\.wheel_speed: expected shape \(1,\), got \(2,\)"),
    )
]

# a wheel's max_speed beyond 1e4 rad/s (the largest wheel speed a State takes) refused where the wheel is declared
add_file("wheels/max-speed-huge.toml", _SIM + _WHEEL.replace("max_speed = 600.0", "max_speed = 2e4"))
CASES += [
    cli(
        "cli-simulate-wheel-max-speed-huge",
        "simulate {files}/wheels/max-speed-huge.toml --out out",
        r"wheels\[0\] \(rw_z\)\.max_speed: 20000 rad/s is beyond 10000 rad/s \(about 95,000 rpm\).*check the units",
    ),
    api(
        "wheel-max-speed-huge",
        lambda f: ff.load("papadopoulos1992", wheels=[{**_WHEELED[0], "max_speed": 1e5}]),
        ModelError,
        r"^wheels\[0\] \(rw\)\.max_speed: 100000 rad/s is beyond 10000 rad/s",
    ),
    api(
        "wheel-max-speed-huge-builder",
        lambda f: ff.ModelBuilder("t").add_wheel("rw", axis=[0.0, 0.0, 1.0], inertia=0.1, max_speed=1e300),
        ModelError,
        r"^wheels\[0\] \(rw\)\.max_speed: 1e\+300 rad/s is beyond 10000 rad/s",
    ),
]

# rollouts: the batch, its size, and the per-trajectory parameters (fields of State and of JointPD)
_BIG = 10**8  # trajectories, as a broadcast view: nothing of that size exists until a rollout would make it
CASES += [
    # an empty batch is a batch (its empty result: tests/simulation/test_rollout_inputs.py), checked as any other
    api(
        "rollout-empty-batch-1e12-s",
        lambda f: ff.rollout(_model(), ff.State(q=np.zeros((0, 4))), 1e12, dt=0.01),
        MemoryBudgetError,
        r"^a rollout of 0 trajectories x 100000000000002 recorded states would need about .* of memory",
    ),
    api(
        "rollout-empty-batch-pd-gains-wrong-rows",
        lambda f: ff.rollout(_model(), ff.State(q=np.zeros((0, 4))), 0.1, dt=0.01, controller=ff.JointPD(kp=np.ones((3, 4)), kd=1.0)),
        ShapeError,
        r"^JointPD\.kp: shape \(3, 4\) does not broadcast to the states' \(0, 4\) \(trajectories x joints\)",
    ),
    api(
        "rollout-two-batch-axes",
        lambda f: ff.rollout(_model(), ff.State(q=np.zeros((2, 3, 4))), 0.1, dt=0.01),
        ShapeError,
        r"one leading batch axis .*got a state of shape \(2, 3, 21\)",
    ),
    api(
        "rollout-not-a-state",
        lambda f: ff.rollout(_model(), np.zeros((3, 21)), 0.1, dt=0.01),
        TypeError,
        r"^initial_states: expected a freefloat\.State whose fields have a leading batch axis, got ndarray",
    ),
    api(
        "rollout-1e8-trajectories",
        lambda f: ff.rollout(_model(), ff.State(q=np.broadcast_to(_Q, (_BIG, 4))), 10.0, dt=0.01),
        MemoryBudgetError,
        r"^a rollout of 100000000 trajectories x 1002 recorded states would need about .* of memory",
    ),
    api(
        "rollout-1e12-s",
        lambda f: ff.rollout(_model(), ff.State(q=np.tile(_Q, (2, 1))), 1e12, dt=0.01),
        MemoryBudgetError,
        r"^a rollout of 2 trajectories x 100000000000002 recorded states",
    ),
    api(
        "rollout-fields-do-not-broadcast",
        lambda f: ff.rollout(_model(), ff.State(q=np.zeros((3, 4)), qdot=np.zeros((2, 4))), 0.1, dt=0.01),
        ShapeError,
        r"^State: the fields' leading \(batch\) shapes do not broadcast: q \(3, 4\), qdot \(2, 4\)",
    ),
    api(
        "rollout-q-wrong-length",
        lambda f: ff.rollout(_model(), ff.State(q=np.zeros((3, 5))), 0.1, dt=0.01),
        ShapeError,
        r"^State\.q: expected shape \(\.\.\., 4\)",
    ),
    api(
        "rollout-q-nan-row",
        lambda f: ff.rollout(_model(), ff.State(q=np.array([_Q, [np.nan, 0, 0, 0]])), 0.1, dt=0.01),
        ValueError,
        r"^State\.q: has NaN or infinite entries",
    ),
    api(
        "rollout-omega-inf-row",
        lambda f: ff.rollout(_model(), ff.State(q=np.tile(_Q, (2, 1)), omega=[[0, 0, 0], [0, 0, np.inf]]), 0.1, dt=0.01),
        ValueError,
        r"^State\.omega: has NaN or infinite entries",
    ),
    api(
        "rollout-q-empty-rows",
        lambda f: ff.rollout(_model(), ff.State(q=np.zeros((3, 0))), 0.1, dt=0.01),
        ShapeError,
        r"^State\.q: expected shape \(\.\.\., 4\)",
    ),
    api(
        "rollout-pd-gains-wrong-rows",
        lambda f: ff.rollout(_model(), ff.State(q=np.tile(_Q, (4, 1))), 0.1, dt=0.01, controller=ff.JointPD(kp=np.ones((3, 4)), kd=1.0)),
        ShapeError,
        r"^JointPD\.kp: shape \(3, 4\) does not broadcast to the states' \(4, 4\) \(trajectories x joints\); give a scalar",
    ),
    api(
        "rollout-pd-gains-empty",
        lambda f: ff.rollout(_model(), ff.State(q=np.tile(_Q, (4, 1))), 0.1, dt=0.01, controller=ff.JointPD(kp=1.0, kd=np.ones(0))),
        ShapeError,
        r"^JointPD\.kd: shape \(0,\) does not broadcast to the states' \(4, 4\)",
    ),
    api(
        "rollout-pd-reference-wrong-length",
        lambda f: ff.rollout(
            _model(), ff.State(q=np.tile(_Q, (2, 1))), 0.1, dt=0.01, controller=ff.JointPD(kp=1.0, kd=1.0, q_ref=np.zeros(3))
        ),
        ShapeError,
        r"^JointPD\.q_ref: shape \(3,\) does not broadcast",
    ),
    api(
        "rollout-pd-gain-nan", lambda f: ff.JointPD(kp=[[1.0, np.nan, 1.0, 1.0]], kd=1.0), ValueError, r"^JointPD\.kp: has NaN or infinite"
    ),
    api("rollout-pd-gain-inf", lambda f: ff.JointPD(kp=1.0, kd=[[np.inf] * 4]), ValueError, r"^JointPD\.kd: has NaN or infinite"),
]

# ff.simulate checks a JointPD's shapes against the model's joints before the run (was: a failed run at t = 0)
CASES += [
    api(
        f"simulate-pd-{id}",
        lambda f, given=given: ff.simulate(_model(), ff.State(q=_Q), 0.1, ff.JointPD(**{"kp": 1.0, "kd": 1.0, **given})),
        ShapeError,
        match,
    )
    for id, given, match in (
        ("gains-wrong-length", {"kp": np.ones(3)}, r"^JointPD\.kp: shape \(3,\) does not broadcast to the model's 4 joints \(4,\)"),
        ("gains-per-trajectory", {"kd": np.ones((2, 4))}, r"^JointPD\.kd: shape \(2, 4\) does not broadcast to the model's 4 joints"),
        (
            "feedforward-wrong-joints",
            {"feedforward": np.zeros((2, 3)), "feedforward_period": 0.01},
            r"^JointPD\.feedforward: samples of shape \(3,\) does not broadcast to the model's 4 joints",
        ),
    )
]

# reaction wheel speeds (initial.wheel_speed of a scenario reads the same field)
CASES += [
    api(
        f"wheel-speed-{id}",
        lambda f, value=value: ff.State(wheel_speed=value).resolve(ff.load("papadopoulos1992", wheels=_WHEELED)),
        expect,
        match,
    )
    for id, value, expect, match in (
        ("huge", [1e300], ValueError, r"^State\.wheel_speed: 1e\+300 is beyond 10000 \(rad/s\), which no reaction wheel turns at"),
        ("above-max-rate", [2e4], ValueError, r"^State\.wheel_speed: 2e\+04 is beyond 10000 \(rad/s\)"),
        ("nan", [np.nan], ValueError, r"^State\.wheel_speed: has NaN or infinite entries"),
        ("inf", [-np.inf], ValueError, r"^State\.wheel_speed: has NaN or infinite entries"),
        ("text", ["fast"], TypeError, r"^State\.wheel_speed: expected real numbers, got text"),
        ("scalar", 3.0, ShapeError, r"^State\.wheel_speed: expected one value per reaction wheel, shape \(\.\.\., W\)"),
        ("too-many", [1.0, 2.0], ShapeError, r"^State\.wheel_speed: expected shape \(\.\.\., 1\) \(one speed per reaction wheel"),
        ("empty", [], ShapeError, r"^State\.wheel_speed: expected shape \(\.\.\., 1\)"),
    )
]

# --out: the forms tests/test_bad_inputs.py's BAD_OUTS lacks, on every command with --out (campaign's are its own);
# each refused before the work (simulate: before its estimate), naming --out
_OUT_COMMANDS = {"demo": "demo", "reproduce": "reproduce 1992", "workspace": "workspace papadopoulos1992"}
_OUT_COMMANDS |= {"capture": f"capture {_CAPTURE}", "simulate": f"simulate {_SCENARIO}"}
_OUTS = [
    ("file-trailing-slash", "{files}/empty.toml/", r"^error: --out \S+/empty\.toml: exists and is not a directory; choose another --out"),
    (
        "under-a-file-trailing-slash",
        "{files}/empty.toml/sub/",
        r"^error: --out \S+/empty\.toml/sub: cannot create this folder \(Not a directory\)",
    ),
    (
        "unwritable",
        "/sys/freefloat-out",
        r"^error: --out /sys/freefloat-out: cannot create this folder \(.*\); choose a folder you can write to",
    ),
    ("under-a-device", "/dev/null/out", r"^error: --out /dev/null/out: cannot create this folder \(Not a directory\)"),
    ("through-a-file-and-back", "{files}/empty.toml/../out", r"^error: --out \S+/empty\.toml/\.\./out: cannot create this folder"),
    # an existing folder nothing can be made in (was: the run's estimate, then "[Errno 2] ... '/proc/.freefloat-staging-...'")
    ("existing-unwritable", "/proc", r"^error: --out /proc: cannot write here \(.*\); choose a folder you can write to"),
    ("existing-unwritable-sys", "/sys", r"^error: --out /sys: cannot write here \(.*\); choose a folder you can write to"),
]
CASES += [
    cli(f"cli-{command}-out-{id}", f"{prefix} --out {out}", match) for command, prefix in _OUT_COMMANDS.items() for id, out, match in _OUTS
]

# capture checks --out before it estimates a long capture sequence and asks to confirm it (as simulate does)
_LONG = (_ROOT / "examples" / "scenarios" / "tumbling_satellite_capture.toml").read_text().replace("duration = 30.0", "duration = 1e5", 1)
add_file("out/capture-long.toml", _LONG)
CASES += [
    cli(f"cli-capture-long-out-{id}", f"capture {{files}}/out/capture-long.toml --out {out}", match)
    for id, out, match in (
        ("is-a-file", "{files}/empty.toml", r"^error: --out \S+/empty\.toml: exists and is not a directory"),
        ("unwritable", "/proc", r"^error: --out /proc: cannot write here"),
    )
]


def _out_through(*chain: str) -> None:
    """check_targets of ``--out dl/sub`` with ``dl`` the first of symbolic links in the working directory, each pointing
    at the next of ``chain`` (the last one's target does not exist)."""
    from freefloat.io.outputs import check_targets

    names = [f"dl{i or ''}" for i in range(len(chain))]
    made = [Path.cwd() / name for name in names]
    for link, target in zip(made, [*names[1:], chain[-1]], strict=True):
        link.symlink_to(target)
    try:
        check_targets(Path("dl") / "sub", ["trajectory.json"], overwrite=False)
    finally:
        for link in made:
            link.unlink()


CASES += [  # a broken link on the way to --out: named, with the target it misses (the end of a chain of links)
    api(
        "out-through-a-broken-link",
        lambda f: _out_through("nowhere/x"),
        OSError,
        r"^--out dl/sub: dl is a symbolic link to /\S+/work/nowhere/x, which does not exist",
    ),
    api(
        "out-through-a-chain-of-links",
        lambda f: _out_through("dl1", "dl2", "gone/x"),
        OSError,
        r"^--out dl/sub: dl is a symbolic link to /\S+/work/gone/x, which does not exist",
    ),
]

# out= on the batched calls: refused before the work, naming out, the expected shape or layout and the fix
_Q70 = np.tile(_Q, (70, 1))


def _read_only(shape: tuple[int, ...]) -> np.ndarray:
    out = np.empty(shape)
    out.flags.writeable = False
    return out


CASES += [
    api(
        "out-wrong-shape",
        lambda f: ff.generalized_jacobian(_model(), _Q70, out=np.empty((70, 12, 5))),
        ShapeError,
        r"^out: expected shape \(70, 12, 4\) \(the result's\), got \(70, 12, 5\); pass out=np\.empty\(\(70, 12, 4\)\)",
    ),
    api(
        "out-batched-for-one-configuration",
        lambda f: ff.system_inertia_matrix(_model(), _Q, out=np.empty((1, 10, 10))),
        ShapeError,
        r"^out: expected shape \(10, 10\) \(the result's\), got \(1, 10, 10\)",
    ),
    api(
        "out-float32",
        lambda f: ff.system_inertia_matrix(_model(), _Q70, out=np.empty((70, 10, 10), dtype=np.float32)),
        TypeError,
        r"^out: expected dtype float64, got float32; pass out=np\.empty\(\(70, 10, 10\)\) \(float64\)",
    ),
    api(
        "out-a-list",
        lambda f: ff.nonlinear_forces(_model(), _Q70, np.zeros(10), out=[0.0] * 10),
        TypeError,
        r"^out: expected a float64 numpy array of shape \(70, 10\), got list",
    ),
    api(
        "out-transposed",
        lambda f: ff.generalized_jacobian(_model(), _Q70, out=np.empty((4, 12, 70)).T),
        ValueError,
        r"^out: is not C-contiguous and aligned .*; pass out=np\.empty\(\(70, 12, 4\)\)",
    ),
    api(
        "out-read-only",
        lambda f: ff.forward_dynamics(_model(), _Q70, np.zeros(10), out=_read_only((70, 10))),
        ValueError,
        r"^out: is read-only; pass out=np\.empty\(\(70, 10\)\)",
    ),
    api(
        "out-is-the-input",
        lambda f: ff.nonlinear_forces(_model(), _Q70, (v := np.zeros((70, 10))), out=v),
        ValueError,
        r"^out: shares memory with velocity, which the call reads while it writes out; pass an array of its own",
    ),
    api(
        "out-barycentric",
        lambda f: ff.generalized_jacobian(_model(), _Q70, method="barycentric", out=np.empty((70, 12, 4))),
        ValueError,
        r"^out: method='barycentric' \(the numpy reference\) makes its own arrays and takes no out=",
    ),
    api(
        "out-inverse-dynamics-one-array",
        lambda f: ff.inverse_dynamics(_model(), _Q70, np.zeros(10), np.zeros(10), out=np.empty((70, 10))),
        TypeError,
        r"^out: expected a tuple of three arrays \(spacecraft_force, spacecraft_torque, joint_torque",
    ),
]

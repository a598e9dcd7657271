"""A smoke run of an installed freefloat: the library, every command of the ``freefloat`` CLI and a campaign.

``python tests/lowest/smoke.py`` (the Python of the environment to check: ``make test-lowest`` runs it in
``.venv-lowest``, at the lowest versions pyproject.toml declares; it must pass at the newest versions too). It checks

* the library, with every warning an error (a deprecation of a dependency fails it): ``import freefloat``, J* and H+
  of a built-in model (the engine's compiled recursion against the barycentric sums of the papers; a batch against
  its rows), the MJCF, URDF and TOML readers, and a 0.2 s simulation with a built-in controller (a joint PD: the
  system's momentum stays zero, the joints move towards the set point);
* ``freefloat --help`` and every command it lists, each once on a built-in model or a small scenario written into a
  temporary folder; each must exit 0 and print no ``warning:`` or ``error:`` line, a DeprecationWarning an error
  (:data:`COMMANDS`; a command the help lists that this script does not run fails it: add a new command here);
* ``freefloat campaign`` on a local Dask cluster: a few runs that record time series (Parquet and Zarr), stopped
  after two by ``--max-runs``, then ``--resume``, then its report; the stored runs and series read back.

It prints one line per step with its wall time and exits 1 at the first failure, with the command and its output.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"
FREEFLOAT = Path(sys.executable).with_name("freefloat")  # the console script of this environment

#: The commands of ``freefloat --help``, each with what it is run on (see :func:`commands`).
COMMANDS = ("inspect", "specialise", "kernels", "demo", "workspace", "capture", "simulate", "reproduce", "campaign")

#: A two-link free-floating arm in MJCF (MuJoCo's parser reads it): the spacecraft (a free joint) and two hinges.
TINY_MJCF = """<mujoco model="tiny">
  <worldbody>
    <body name="base">
      <freejoint/>
      <inertial pos="0 0 0" mass="100" diaginertia="10 10 10"/>
      <body name="link1" pos="0.5 0 0">
        <joint name="j1" type="hinge" axis="0 0 1"/>
        <inertial pos="0.5 0 0" mass="5" diaginertia="0.1 0.5 0.5"/>
        <body name="link2" pos="1 0 0">
          <joint name="j2" type="hinge" axis="0 0 1"/>
          <inertial pos="0.5 0 0" mass="3" diaginertia="0.05 0.3 0.3"/>
          <site name="tip" pos="1 0 0"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""

#: The joint-PD scenario of the examples, shortened to 0.2 s (``freefloat simulate`` and the campaign's runs).
SCENARIO = """description = "smoke: the 1992 two-arm system, joint PD, 0.2 s"
model = "papadopoulos1992"
duration = 0.2

[initial]
q_deg = [0.0, 90.0, 180.0, -90.0]

[integrator]
method = "RK4"
fixed_step = 0.002
sample_period = 0.01
output_period = 0.02

[controller]
type = "joint_pd"
kp = 20.0
kd = 30.0
q_ref_deg = { arm1_q1 = 40.0, arm1_q2 = 60.0, arm2_q1 = 170.0, arm2_q2 = -90.0 }

[limits]
joint_torque = 10.0
"""

#: Three runs of :data:`SCENARIO` (a grid over the joint gain), each keeping a scalar and two time series.
CAMPAIGN = """description = "smoke: three joint-PD runs with their series"
scenario = "scenario.toml"

[parameters]
"controller.kp" = { values = [10.0, 20.0, 30.0] }

[record]
scalars = ["kinetic_energy.final"]
series = ["q", "omega"]
"""


class SmokeFailure(Exception):
    """One check of the smoke run failed; the message says which and what was seen."""


def check(condition: bool, what: str) -> None:
    if not condition:
        raise SmokeFailure(what)


def step(name: str, action: Callable[[], object]) -> None:
    start = time.perf_counter()
    action()
    print(f"ok {time.perf_counter() - start:7.1f} s  {name}", flush=True)


def run(args: Sequence[str | Path], *, cwd: Path, env: dict[str, str] | None = None) -> str:
    """``freefloat ARGS`` in ``cwd`` (``env`` added to the environment): exit 0 and no warning or error line on
    stderr, else a SmokeFailure; its stdout. A DeprecationWarning, which the CLI leaves hidden, is an error in it and in
    the campaign's worker processes (``PYTHONWARNINGS``): an old dependency's deprecation fails the smoke run."""
    command = [str(FREEFLOAT), *map(str, args)]
    environ = {**os.environ, "PYTHONWARNINGS": "error::DeprecationWarning", **(env or {})}
    done = subprocess.run(command, cwd=cwd, env=environ, capture_output=True, text=True, timeout=900, check=False)
    noisy = [line for line in done.stderr.splitlines() if line.startswith(("warning:", "error:", "Traceback"))]
    if done.returncode != 0 or noisy:
        raise SmokeFailure(f"{' '.join(command)}: exit {done.returncode}\n--- stdout\n{done.stdout}--- stderr\n{done.stderr}")
    return done.stdout


def library(tmp: Path) -> None:
    """J*, H+, the model readers and a simulation, every warning an error."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        import freefloat as ff

        model = ff.models.papadopoulos1992()
        q = np.radians([0.0, 90.0, 180.0, -90.0])
        batch = np.stack([q, q + 0.3, q - 0.7])
        jstar = ff.generalized_jacobian(model, batch)
        check(jstar.shape == (3, 6 * len(model.end_effector_names), model.n_joints), f"J* batch shape {jstar.shape}")
        check(np.allclose(jstar, ff.generalized_jacobian(model, batch, method="barycentric"), atol=1e-10), "J*: recursive != barycentric")
        check(np.array_equal(jstar[1], ff.generalized_jacobian(model, batch[1])), "J*: a batch row != the single call")
        hplus = ff.system_inertia_matrix(model, batch)
        check(np.allclose(hplus, ff.system_inertia_matrix(model, batch, method="barycentric"), atol=1e-9), "H+: recursive != barycentric")
        symmetric = np.allclose(hplus, np.swapaxes(hplus, -1, -2))
        check(symmetric and bool(np.all(np.linalg.eigvalsh(hplus) > 0)), "H+ not symmetric positive definite")

        mjcf = tmp / "tiny.xml"
        mjcf.write_text(TINY_MJCF)
        tiny = ff.load(mjcf)
        check(tiny.n_joints == 2 and np.isclose(tiny.total_mass, 108.0), f"MJCF: {tiny.n_joints} joints, {tiny.total_mass} kg")
        urdf = ff.load(EXAMPLES / "models" / "six_dof_arm.urdf")
        check(urdf.n_joints == 6, f"URDF: {urdf.n_joints} joints")
        toml = ff.load(EXAMPLES / "models" / "papadopoulos1991.toml")
        check(toml.n_joints == 2, f"TOML: {toml.n_joints} joints")

        start = ff.State(q=q)
        q_ref = q + np.radians([20.0, -20.0, 10.0, 10.0])
        law = ff.JointPD(kp=20.0, kd=30.0, q_ref=q_ref)
        trajectory = ff.simulate(model, start, 0.2, law, fixed_step=0.002)
        check(trajectory.status == "finished" and np.isclose(trajectory.t[-1], 0.2), f"simulate: {trajectory.status} at {trajectory.t[-1]}")
        check(bool(np.all(np.abs(trajectory.angular_momentum) < 1e-9)), "simulate: the angular momentum left zero")
        check(bool(np.all(np.abs(trajectory.r_cm - trajectory.r_cm[0]) < 1e-9)), "simulate: the system CM moved")
        before, after = np.abs(q_ref - q), np.abs(q_ref - trajectory.q[-1])
        check(bool(np.all(after < before)), f"simulate: the joints did not move towards the set point ({before} -> {after})")


def help_commands(tmp: Path) -> list[str]:
    """The commands ``freefloat --help`` lists."""
    text = run(["--help"], cwd=tmp)
    listed = text.split("Commands:", 1)[1].splitlines()[1:] if "Commands:" in text else []
    names = [line.split()[0] for line in listed if line.startswith("  ") and line.split()]
    check(bool(names), f"freefloat --help lists no commands:\n{text}")
    return names


def commands(tmp: Path) -> dict[str, Callable[[], object]]:
    """Each CLI command on small inputs in ``tmp`` (:data:`COMMANDS`, in that order)."""
    (tmp / "scenario.toml").write_text(SCENARIO)
    capture = EXAMPLES / "scenarios" / "papadopoulos1992_capture.toml"
    return {
        "inspect": lambda: [
            run(["inspect"], cwd=tmp),
            run(["inspect", "papadopoulos1992", "--json"], cwd=tmp),
            run(["inspect", tmp / "tiny.xml"], cwd=tmp),
            run(["inspect", EXAMPLES / "models" / "six_dof_arm.urdf"], cwd=tmp),
        ],
        # (into a cache folder of its own: the specialised kernels it makes would serve this user's later calls)
        "specialise": lambda: run(
            ["specialise", "papadopoulos1991", "--kind", "jstar"], cwd=tmp, env={"FREEFLOAT_CACHE_DIR": str(tmp / "cache")}
        ),
        "kernels": lambda: kernels(tmp),
        "demo": lambda: run(["demo", "--out", tmp / "demo"], cwd=tmp),
        "workspace": lambda: run(["workspace", "papadopoulos1992-one-arm", "--samples", "16", "--out", tmp / "workspace"], cwd=tmp),
        "capture": lambda: run(["capture", capture, "--out", tmp / "capture"], cwd=tmp),
        "simulate": lambda: run(["simulate", tmp / "scenario.toml", "--out", tmp / "simulate", "--no-progress"], cwd=tmp),
        "reproduce": lambda: run(["reproduce", "1992", "--out", tmp / "reproduce"], cwd=tmp),
        "campaign": lambda: campaign(tmp),
    }


def kernels(tmp: Path) -> None:
    """``freefloat kernels``: the text and the JSON agree on the setting and on where this machine's kernels are."""
    text = run(["kernels"], cwd=tmp)
    status = json.loads(run(["kernels", "--json"], cwd=tmp))
    check(f"FREEFLOAT_KERNELS={status['setting']}" in text, f"freefloat kernels: setting {status['setting']!r} not in\n{text}")
    check(str(status["folder"]) in text, f"freefloat kernels: folder {status['folder']} not in\n{text}")
    native = status["native"]
    check(isinstance(native, int) and native > 0, f"freefloat kernels: {native!r} native kernels after the warm-up")


def campaign(tmp: Path) -> None:
    """Two runs, then ``--resume`` for the third, on a local cluster of one worker; the runs, series and report read back."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        import freefloat as ff

        spec_file = tmp / "campaign.toml"
        spec_file.write_text(CAMPAIGN)
        out = tmp / "campaign"
        flags = ["--out", out, "--workers", "1", "--no-progress"]
        run(["campaign", spec_file, *flags, "--max-runs", "2"], cwd=tmp)
        check(ff.campaigns.read_runs(out).num_rows == 2, "campaign --max-runs 2: not 2 runs stored")
        run(["campaign", spec_file, *flags, "--resume"], cwd=tmp)
        table = ff.campaigns.read_runs(out)
        check(table.num_rows == 3 and table.column("status").to_pylist() == ["ok"] * 3, f"campaign --resume: {table.to_pydict()}")
        energies = table.column("kinetic_energy.final").to_pylist()
        check(len(set(energies)) == 3 and all(e > 0 for e in energies), f"campaign: kinetic energies {energies}")
        for run_id in table.column("run_id").to_pylist():
            series = ff.campaigns.read_series(out, run_id)
            check(set(series) == {"t", "q", "omega"}, f"campaign: series of {run_id}: {sorted(series)}")
            shape = series["q"].shape
            check(np.isclose(series["t"][-1], 0.2) and shape == (len(series["t"]), 4), f"campaign: {run_id}'s q {shape}")
        report = out / "report" / "summary.md"
        check(report.is_file() and "kinetic_energy.final" in report.read_text(), f"campaign: no report at {report}")


def main() -> int:
    print(f"freefloat smoke run with {sys.executable}", flush=True)
    try:
        with tempfile.TemporaryDirectory(prefix="freefloat-smoke-") as folder:
            tmp = Path(folder)
            step("library: J*, H+, MJCF/URDF/TOML models, a 0.2 s joint-PD simulation", lambda: library(tmp))
            listed = help_commands(tmp)
            check(sorted(listed) == sorted(COMMANDS), f"freefloat --help lists {listed}; this script runs {list(COMMANDS)}: add it")
            for name, action in commands(tmp).items():
                step(f"freefloat {name}", action)
    except SmokeFailure as failure:
        print(f"FAILED: {failure}", file=sys.stderr, flush=True)
        return 1
    print("smoke run passed", flush=True)
    return 0


if __name__ == "__main__":
    os.environ.setdefault("MPLBACKEND", "Agg")
    sys.exit(main())

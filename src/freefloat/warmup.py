"""Compile (or load) the engine's kernels that a new user's first calls need, before they are needed.

``python -m freefloat.warmup`` runs the calls of :data:`PARTS` in turn: the maps and dynamics, the simulations and the
rollout with a joint PD, the 1991 controllers' compiled laws, and the commands the README shows after ``make demo``
(``freefloat demo``, ``workspace``, and where the examples folder is at hand ``simulate`` and ``capture``), each
writing into a temporary folder that is removed after. It is what ``freefloat kernels --compile`` runs, what the
background compile of this machine's own kernels runs (``--background``: at low priority, then the marker
``native-compile.done`` in the cache folder), and, with ``NUMBA_CPU_NAME=generic``, what ``make kernels`` runs to build
the portable kernels freefloat ships. ``python -m freefloat.warmup PART`` runs one part.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

from .engine import cache_dir, recorded_compiles

#: The examples folder of a checkout (absent from an installed wheel: the commands that need it are left out).
EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def engine() -> None:
    """The maps, forward and inverse dynamics, the simulations and the rollout with a joint PD (one kernel per
    driver: a batch on threads runs the same one, from the small parallel loop that calls it, compiled here for each
    driver's signature by a batch of the drivers' threshold)."""
    import numpy as np

    from . import mechanics, models, simulation
    from .core.state import State
    from .engine import PARALLEL_MIN

    model = models.papadopoulos1992()
    n = model.n_joints
    q = np.zeros((PARALLEL_MIN, n))
    v = np.zeros((PARALLEL_MIN, 6 + n))
    mechanics.generalized_jacobian(model, q)
    mechanics.system_inertia_matrix(model, q)
    mechanics.point_jacobian(model, q, 1)
    mechanics.end_effector_positions(model, q)
    mechanics.forward_kinematics(model, q)
    mechanics.inverse_dynamics(model, q, v, v)
    mechanics.forward_dynamics(model, q, v)
    state = State(q=np.zeros(n))
    pd = simulation.JointPD(kp=1.0, kd=1.0)
    simulation.simulate(model, state, 0.01, pd, fixed_step=1e-3)
    simulation.simulate(model, state, 0.01, lambda t, s: pd(t, s), fixed_step=1e-3)
    simulation.simulate(model, state, 0.01, pd)
    simulation.rollout(model, State(q=np.zeros((2, n))), 0.01, dt=1e-3, controller=pd)


def laws() -> None:
    """The 1991 controllers' numpy form and their compiled laws in the fixed-step loop and the rollout."""
    import numpy as np

    from . import simulation
    from .control import Detumble, OperationalSpaceController, TransposedJacobianController
    from .core.state import State
    from .papers.paper1991 import section5_setup

    robot, task, start, target = section5_setup()
    for law in (OperationalSpaceController(robot, task, target, 30.0, 60.0), TransposedJacobianController(robot, task, target, 30.0, 60.0)):
        law(0.0, start)
        simulation.simulate(robot, start, 0.02, law, fixed_step=0.01)
    simulation.simulate(robot, start, 0.02, Detumble(robot), fixed_step=0.01)
    states = State(q=np.repeat(np.asarray(start.q)[None], 2, axis=0))  # the paper's start: J_z not singular
    simulation.rollout(robot, states, 0.01, dt=1e-3, controller=OperationalSpaceController(robot, task, target, 30.0, 60.0))


def commands() -> None:
    """The commands the README shows after ``make demo``, each into a temporary folder (in child processes: the CLI
    is the package's top)."""
    with tempfile.TemporaryDirectory(prefix="freefloat-warmup-") as folder:
        out = Path(folder)
        runs = [["demo", "--out", str(out / "demo")], ["workspace", "papadopoulos1992", "--payload-mass", "400", "--payload-inertia", "25"]]
        scenarios = EXAMPLES / "scenarios"
        if (scenarios / "papadopoulos1992_joint_pd.toml").is_file():
            runs.append(["simulate", str(scenarios / "papadopoulos1992_joint_pd.toml"), "--out", str(out / "simulate"), "--yes"])
        if (scenarios / "papadopoulos1992_capture.toml").is_file():
            runs.append(["capture", str(scenarios / "papadopoulos1992_capture.toml"), "--out", str(out / "capture"), "--yes"])
        for args in runs:
            subprocess.run([sys.executable, "-m", "freefloat", *args], check=True, stdout=subprocess.DEVNULL, cwd=folder)


#: The parts, in the order :func:`main` runs them.
PARTS: dict[str, Callable[[], None]] = {"engine": engine, "laws": laws, "commands": commands}


#: The environment variable naming a JSON file into which :func:`main` writes the seconds each kernel took to compile
#: (``make kernels`` keeps them in the portable kernels' manifest: the estimates of a run that compiles quote them).
COMPILE_TIMES_ENV = "FREEFLOAT_COMPILE_TIMES"


def main(argv: list[str]) -> int:
    """Run one part (``PART``) or all of them; ``--background``: at low priority, then mark the cache folder done."""
    background = "--background" in argv
    names = [name for name in argv if not name.startswith("--")] or list(PARTS)
    unknown = [name for name in names if name not in PARTS]
    if unknown:
        print(f"freefloat.warmup: no part {unknown[0]!r}: the parts are {', '.join(PARTS)}", file=sys.stderr)
        return 2
    if background and hasattr(os, "nice"):
        os.nice(10)
    times = os.environ.get(COMPILE_TIMES_ENV)
    with recorded_compiles() as took:
        for name in names:
            PARTS[name]()
    if times:
        Path(times).write_text(json.dumps(took, indent=1, sort_keys=True))
    if background:
        (cache_dir() / "native-compile.done").write_text("done\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

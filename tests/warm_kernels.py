"""Compile the engine's generic kernels into the user's cache before ``make test`` runs the suite, in two processes
with disjoint sets at once (the control laws and their loops; every other kernel), so that the suite's two workers do
not compile the same kernels side by side on a fresh clone. A warm cache makes this a second or two. The sets are
balanced by their cold compile times (2026-11-27, both parts at once on the 2-core VM, since the drivers' threaded
twins are gone: the laws with the forward-dynamics batches 249 s, the rest 153 s; the forward dynamics now with the
rest; before, with the twins: 232 s and 339 s).

``python tests/warm_kernels.py`` runs both parts and prints the time they took; ``python tests/warm_kernels.py PART``
runs one. ``benchmarks/run.py`` calls both parts in its own process before it times anything.
"""

from __future__ import annotations

import subprocess
import sys
import time


def laws() -> None:
    """The 1991 controllers' numpy form and their compiled laws in the fixed-step loop and the rollout."""
    import numpy as np

    import freefloat as ff
    from freefloat.control import Detumble, OperationalSpaceController, TransposedJacobianController
    from freefloat.papers.paper1991 import section5_setup

    robot, task, start, target = section5_setup()
    for law in (OperationalSpaceController(robot, task, target, 30.0, 60.0), TransposedJacobianController(robot, task, target, 30.0, 60.0)):
        law(0.0, start)
        ff.simulate(robot, start, 0.02, law, fixed_step=0.01)
    ff.simulate(robot, start, 0.02, Detumble(robot), fixed_step=0.01)
    states = ff.State(q=np.repeat(np.asarray(start.q)[None], 2, axis=0))  # the paper's start: J_z not singular
    ff.rollout(robot, states, 0.01, dt=1e-3, controller=OperationalSpaceController(robot, task, target, 30.0, 60.0))


def engine() -> None:
    """The maps, forward and inverse dynamics, the simulations and the rollout with a joint PD
    (one kernel per driver: a batch on threads runs the same one, from the small parallel loop that calls it,
    ``_threads._fan_out``, compiled here for each driver's signature by a batch of the drivers' threshold)."""
    import numpy as np

    import freefloat as ff
    from freefloat.engine.drivers import Batched

    model = ff.models.papadopoulos1992()
    n = model.n_joints
    q = np.zeros((Batched.PARALLEL_MIN, n))
    v = np.zeros((Batched.PARALLEL_MIN, 6 + n))
    ff.generalized_jacobian(model, q)
    ff.system_inertia_matrix(model, q)
    ff.point_jacobian(model, q, 1)
    ff.end_effector_positions(model, q)
    ff.forward_kinematics(model, q)
    ff.inverse_dynamics(model, q, v, v)
    ff.forward_dynamics(model, q, v)
    state = ff.State(q=np.zeros(n))
    pd = ff.JointPD(kp=1.0, kd=1.0)
    ff.simulate(model, state, 0.01, pd, fixed_step=1e-3)
    ff.simulate(model, state, 0.01, lambda t, s: pd(t, s), fixed_step=1e-3)
    ff.simulate(model, state, 0.01, pd)
    ff.rollout(model, ff.State(q=np.zeros((2, n))), 0.01, dt=1e-3, controller=pd)


PARTS = {"laws": laws, "engine": engine}

if __name__ == "__main__":
    if len(sys.argv) > 1:
        PARTS[sys.argv[1]]()
        sys.exit(0)
    start = time.perf_counter()
    running = {name: subprocess.Popen([sys.executable, __file__, name]) for name in PARTS}
    took: dict[str, float] = {}
    while len(took) < len(running):
        for name, process in running.items():
            if name not in took and process.poll() is not None:
                took[name] = time.perf_counter() - start
        time.sleep(0.1)
    failed = [name for name, process in running.items() if process.returncode != 0]
    parts = ", ".join(f"{name} {seconds:.0f} s" for name, seconds in took.items())
    print(f"warm_kernels: the engine's kernels compiled or loaded in {time.perf_counter() - start:.0f} s ({parts})", flush=True)
    sys.exit(1 if failed else 0)

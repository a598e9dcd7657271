"""Coordinated control of a spacecraft and its 7-DOF arm in 3D (1991 eqs. 27 and 29-30), both controllers.

The task z1 (1991 eq. 22) holds the tool position and orientation and the
spacecraft CM position and orientation, with quaternion orientation errors:
12 task rows for 13 degrees of freedom, so J_z is 12 x 13 and the
operational-space controller uses its dynamically consistent generalized
inverse (docs/control.md). The tool moves 0.4 m and turns 20° while the
spacecraft moves 0.1 m and turns 3°, along minimum-jerk straight lines.

    python examples/coordinated_7dof.py [OUT_DIR]      (default out/examples/coordinated_7dof)
"""

import sys
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from scipy.spatial.transform import Rotation

import freefloat as ff

# the output folder is the first argument when this file is run as a script (not when a test runner imports it)
run_directly = Path(sys.argv[0]).name == Path(__file__).name
out = Path(sys.argv[1]) if run_directly and len(sys.argv) > 1 else Path("out/examples/coordinated_7dof")
out.mkdir(parents=True, exist_ok=True)

model = ff.models.spacecraft_7dof()
task = ff.control.TaskSpace.paper1991(model, orientation="quaternion")
state0 = ff.State(q=[0.0, 0.6, 0.0, -1.3, 0.0, 0.9, 0.0]).resolve(model)
start = task.coordinates(state0)
tool_rotation = Rotation.from_quat(start[task.item_slices("tool.orientation")[0]])
sc_position = start[task.item_slices("spacecraft.position")[0]]
goal = task.target(
    tool_position=start[0:3] + np.array([0.2, -0.2, 0.28]),
    tool_orientation=Rotation.from_rotvec(np.radians(20.0) * np.array([0.0, 0.6, 0.8])) * tool_rotation,
    spacecraft_position=sc_position + np.array([0.1, 0.0, 0.0]),
    spacecraft_orientation=Rotation.from_euler("z", 3.0, degrees=True),
)
desired = ff.control.MinimumJerk(start, goal, 3.0, task=task)
DURATION = 8.0

# eq. 27 gains are accelerations (1/s², 1/s): ω = 3 rad/s, critically damped, for every row.
# eq. 29 gains are stiffnesses (N/m, N m/rad) and dampings, per row: tool position, tool orientation,
# spacecraft position, spacecraft orientation. The tool's roll inertia (2.5e-3 kg m²) is ~1e-6 of the
# spacecraft's, so the tool orientation damping must stay small for a 10 ms control step.
stiffness = np.repeat([200.0, 5.0, 6000.0, 4000.0], 3)
damping = np.repeat([100.0, 0.3, 6000.0, 4000.0], 3)
controllers = {
    "operational space (eq. 27)": ff.control.OperationalSpaceController(model, task, desired, kp=9.0, kd=6.0, null_space_damping=20.0),
    "transposed Jacobian (eq. 29)": ff.control.TransposedJacobianController(
        model, task, desired, kp=stiffness, kd=damping, null_space_damping=0.2
    ),
}
fig = Figure(figsize=(11, 7), layout="constrained")
axes = fig.subplots(2, 2, sharex=True)
for col, (name, controller) in enumerate(controllers.items()):
    traj = ff.simulate(model, state0, DURATION, controller, fixed_step=0.01)
    z = task.coordinates(ff.State(q=traj.q, attitude=traj.attitude, r_cm=traj.r_cm))
    e = task.error(goal, z)
    tool_err = np.linalg.norm(e[:, 0:3], axis=1)
    sc_err = np.linalg.norm(e[:, 6:9], axis=1)
    axes[0, col].semilogy(traj.t, tool_err, label="tool position (m)")
    axes[0, col].semilogy(traj.t, np.linalg.norm(e[:, 3:6], axis=1), label="tool orientation (rad)")
    axes[0, col].semilogy(traj.t, sc_err, label="spacecraft position (m)")
    axes[0, col].semilogy(traj.t, np.linalg.norm(e[:, 9:12], axis=1), label="spacecraft orientation (rad)")
    axes[0, col].set_title(name, fontsize=10)
    axes[0, col].set_ylabel("|error to the goal|")
    axes[1, col].plot(traj.t, traj.spacecraft_force, label=["f_x", "f_y", "f_z"])
    axes[1, col].plot(traj.t, traj.spacecraft_torque, "--", label=["n_x", "n_y", "n_z"])
    axes[1, col].set_ylabel("thrust (N), torque (N m, dashed)")
    axes[1, col].set_xlabel("time (s)")
    for ax in axes[:, col]:
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    print(f"{name}: after {DURATION:g} s tool error {tool_err[-1] * 1e3:.2f} mm, spacecraft error {sc_err[-1] * 1e3:.2f} mm")
fig.suptitle("spacecraft_7dof: coordinated tool and spacecraft manoeuvre (minimum-jerk lines, 3 s)")
path = out / "coordinated_7dof.png"
fig.savefig(path, dpi=120)
print(f"wrote {path}")

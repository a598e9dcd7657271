"""The generalized Jacobian J* of a free-floating two-arm system (1992 eq. 14), and what it predicts.

Moving the joints of a free-floating robot moves the spacecraft too. J* maps joint rates to the
end-effector velocities that result once the spacecraft's reaction (zero momentum) is accounted for.
"""

import numpy as np
from scipy.spatial.transform import Rotation

import freefloat as ff

model = ff.models.papadopoulos1992(arms=2)
q = np.radians([30.0, 45.0, -20.0, 60.0])
qdot = np.radians([10.0, 0.0, 0.0, 0.0])  # only arm 1's shoulder moves

J_star = ff.generalized_jacobian(model, q)
v = J_star @ qdot
print("end-effector velocities [m/s, rad/s], spacecraft frame:")
for e, name in enumerate(model.end_effector_names):
    print(f"  {name}: v = {v[6 * e : 6 * e + 3].round(4)}, w = {v[6 * e + 3 : 6 * e + 6].round(4)}")

# Check: step the free-floating system by dt with omega0 = -D^-1 D_q qdot and compare positions.
dt = 1e-6
blocks = ff.inertia_blocks(model, q)
omega0 = -np.linalg.solve(blocks.D, blocks.D_q @ qdot)
attitude = Rotation.from_rotvec(omega0 * dt)
after = ff.end_effector_positions(model, q + qdot * dt, attitude=attitude)
before = ff.end_effector_positions(model, q)
fd = (after - before) / dt
print("finite-difference check, max |J* qdot - d r_E/dt| =", float(np.max(np.abs(fd - v.reshape(2, 6)[:, :3]))))
print("arm 2's end effector moves although its joints are still: the spacecraft reacts.")

"""Every script in examples/ runs to completion and prints what it computes: its numbers are checked here,
against the same quantities computed another way (by hand from the model's numbers, or by another function)."""

from __future__ import annotations

import re
import runpy
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import freefloat as ff
from images import check_png

EXAMPLES = sorted((Path(__file__).resolve().parents[1] / "examples").glob("*.py"))
NUMBER = r"(-?\d+\.?\d*(?:e[-+]?\d+)?)"


def run_example(
    name: str, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> tuple[str, dict[str, Any]]:
    """Run examples/NAME in a scratch directory as ``python examples/NAME`` would: (what it printed, its globals)."""
    monkeypatch.chdir(tmp_path)
    (script,) = [p for p in EXAMPLES if p.name == name]
    monkeypatch.setattr(sys, "argv", [str(script)])  # no arguments (not pytest's)
    scope = runpy.run_path(str(script), run_name="__main__")
    return capsys.readouterr().out, scope


def numbers(text: str) -> np.ndarray:
    return np.array([float(x) for x in re.findall(NUMBER, text)])


def test_every_example_is_checked() -> None:
    checked = {name[5:-8] + ".py" for name in globals() if name.startswith("test_") and name.endswith("_example")}
    assert {p.name for p in EXAMPLES} == checked


def test_generalized_jacobian_example(capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    out, _ = run_example("generalized_jacobian.py", capsys, monkeypatch, tmp_path)
    model = ff.models.papadopoulos1992(arms=2)
    q, qdot = np.radians([30.0, 45.0, -20.0, 60.0]), np.radians([10.0, 0.0, 0.0, 0.0])
    # J* qdot the long way (1992 eqs. 12-14): the spacecraft's reaction omega0 = -D^-1 D_q qdot, then each end
    # effector's point Jacobian J+ applied to [r_cm dot = 0, omega0, qdot]
    blocks = ff.inertia_blocks(model, q)
    velocity = np.concatenate([np.zeros(3), -np.linalg.solve(blocks.D, blocks.D_q @ qdot), qdot])
    for e, name in enumerate(model.end_effector_names):
        expected = ff.point_jacobian(model, q, int(model.end_effector_body[e]), model.end_effector_point[e]) @ velocity
        line = re.search(rf"  {name}: v = \[([^\]]*)\], w = \[([^\]]*)\]", out)
        assert line, out
        np.testing.assert_allclose(numbers(line[1]), expected[:3], atol=5e-5)  # printed to 4 decimals
        np.testing.assert_allclose(numbers(line[2]), expected[3:], atol=5e-5)
    assert abs(expected[0]) > 0.01  # arm 2's end effector moves although only arm 1's shoulder does
    check = re.search(rf"finite-difference check, max \|J\* qdot - d r_E/dt\| = {NUMBER}", out)
    assert check and float(check[1]) < 1e-6, out


def test_model_from_urdf_example(capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    out, _ = run_example("model_from_urdf.py", capsys, monkeypatch, tmp_path)
    lines = out.splitlines()
    assert lines[0] == "Model('tiny_spacecraft': 3 bodies, 2 joints, 1 end effector, mass 213 kg) | planar: False"
    assert lines[1] == "end effector tool0 at [0.7 0.  0. ] in fore"
    # by hand from the URDF: bus 200 kg with its CM at its origin; upper 8 kg, fore 5 kg; at q = 0 the shoulder is
    # at (0.6, 0, 0.3), the elbow 0.8 m further along x, the tool 0.7 m beyond; link CMs 0.4 and 0.35 m along x
    masses = {"bus": 200.0, "upper": 8.0, "fore": 5.0}
    total = sum(masses.values())
    cms = {"bus": np.zeros(3), "upper": np.array([1.0, 0.0, 0.3]), "fore": np.array([1.75, 0.0, 0.3])}
    system_cm = sum(masses[k] * cms[k] for k in masses) / total
    outboard = {"bus": 1.0, "upper": 13.0 / total, "fore": 5.0 / total}  # 1992 eq. 6
    c_star_bus = -np.array([0.6, 0.0, 0.3]) * outboard["upper"]  # 1992 eqs. 5a, 8b: -r_0 mu*_1
    for name in masses:
        row = next(line for line in lines if line.startswith(f"  {name} "))
        mu = re.search(rf"mu\*={NUMBER}", row)
        assert mu and float(mu[1]) == pytest.approx(outboard[name], abs=5e-5), row
        if name == "bus":
            c_star = re.search(r"c\*=\[([^\]]*)\]", row)
            assert c_star, row
            np.testing.assert_allclose(numbers(c_star[1]), c_star_bus, atol=5e-5)
    r_e = re.search(r"r_E at q = 0: \[([^\]]*)\]", out)
    assert r_e, out
    np.testing.assert_allclose(numbers(r_e[1]), np.array([2.1, 0.0, 0.3]) - system_cm, atol=5e-5)
    assert lines[-1] == "TOML round trip equal: True"


def test_coordinated_7dof_example(capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    out, scope = run_example("coordinated_7dof.py", capsys, monkeypatch, tmp_path)
    printed = {
        m[1]: (float(m[2]), float(m[3]))
        for m in re.finditer(rf"^(.*): after 8 s tool error {NUMBER} mm, spacecraft error {NUMBER} mm$", out, flags=re.M)
    }
    assert list(printed) == ["operational space (eq. 27)", "transposed Jacobian (eq. 29)"]
    # the printed errors are the last points of the plotted error curves (tool position, spacecraft position)
    axes = np.array(scope["fig"].axes).reshape(2, 2)
    for col, (tool_mm, sc_mm) in enumerate(printed.values()):
        tool, _, spacecraft, _ = axes[0, col].get_lines()
        assert f"{tool.get_ydata()[-1] * 1e3:.2f}" == f"{tool_mm:.2f}" and f"{spacecraft.get_ydata()[-1] * 1e3:.2f}" == f"{sc_mm:.2f}"
    # the last run (eq. 29): its tool error from the end-effector position, computed here from the final state
    model, traj, goal = scope["model"], scope["traj"], scope["goal"]
    tool_at_end = traj.r_cm[-1] + ff.end_effector_positions(model, traj.q[-1], attitude=traj.attitude[-1])[0]
    assert 1e3 * np.linalg.norm(tool_at_end - goal[0:3]) == pytest.approx(printed["transposed Jacobian (eq. 29)"][0], abs=0.005)
    np.testing.assert_allclose(axes[0, 1].get_lines()[0].get_xdata(), traj.t)
    # eq. 27 with an exact model reaches the goal; eq. 29 with constant gains gets within a few cm
    assert printed["operational space (eq. 27)"][0] < 0.005 and printed["operational space (eq. 27)"][1] < 0.005
    assert 0.1 < printed["transposed Jacobian (eq. 29)"][0] < 50.0
    assert out.splitlines()[-1] == "wrote out/examples/coordinated_7dof/coordinated_7dof.png"
    check_png(tmp_path / "out/examples/coordinated_7dof/coordinated_7dof.png", (11.0, 7.0), 120, min_colours=64)

"""The README's quickstart, the docs' ```python blocks and the README's commands run as written, and say what is true.

What they print and the numbers in their comments are checked against the same quantities computed here another
way (by hand from the paper's Table I, by another function, or from the paper's printed numbers).
"""

from __future__ import annotations

import dataclasses
import json
import re
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ElementTree
from collections.abc import Callable
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import freefloat as ff
from freefloat.core.model import inertia_matrix
from images import check_paper_figure
from printed_1992 import PAPER, paper_or_documented

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
NUMBER = r"(-?\d+(?:\.\d+)?(?:e[-+]?\d+)?)"
#: 1992 Table I: spacecraft 400 kg; each arm's links 40 and 30 kg.
TABLE_I_MASS = 400.0 + 2 * (40.0 + 30.0)


def python_blocks(path: Path = README) -> list[str]:
    return re.findall(r"```python\n(.*?)```", path.read_text(encoding="utf-8"), flags=re.S)


def check_shape_comments(block: str, scope: dict[str, Any]) -> int:
    """Lines ``name = ...  # (2, 3) ...`` or ``expr.shape  # (T, B, 4)``: the value has the shape the comment says (a
    letter is the variable of that name, or any size). Returns how many were checked."""
    checked = 0
    for line in block.splitlines():
        code, _, comment = line.partition("#")
        dims = re.search(r"\((\w+(?:,\s*\w+)*),?\)", comment)
        if not dims or not re.search(r"\(\d|\(\w+,", dims[0]):
            continue
        assigned = re.fullmatch(r"\s*(\w+) = .*", code)
        value = scope[assigned[1]] if assigned else eval(code.strip(), scope)
        shape = value if code.strip().endswith(".shape") else np.shape(value)
        wanted = [d.strip() for d in dims[1].split(",")]
        assert len(shape) == len(wanted), (line, shape)
        for size, want in zip(shape, wanted, strict=True):
            assert size == (int(want) if want.isdigit() else scope.get(want, size)), (line, shape)
        checked += 1
    return checked


def test_readme_has_a_quickstart() -> None:
    assert python_blocks(), "README.md lost its ```python quickstart block"


def test_readme_quickstart_runs(capsys: pytest.CaptureFixture[str]) -> None:
    scope: dict[str, Any] = {"__name__": "readme"}  # one scope: the blocks are read top to bottom
    blocks = python_blocks()
    for block in blocks:
        exec(compile(block, str(README), "exec"), scope)
    out = capsys.readouterr().out.splitlines()
    assert check_shape_comments(blocks[0], scope) == 4  # r_e (2, 3), J (12, 4), H (10, 10), det (100000,)
    # "# 5 bodies, 4 joints, 2 end effectors, 540 kg": the 1992 Table I system
    assert out[0] == f"Model('papadopoulos1992': 5 bodies, 4 joints, 2 end effectors, mass {TABLE_I_MASS:g} kg)"
    assert out[1] == "('arm1_q1', 'arm1_q2', 'arm2_q1', 'arm2_q2') ('arm1_ee', 'arm2_ee') True"
    # det J* < 0 on that share of the samples: det of J*'s in-plane velocity rows (v_x, v_y of each end effector)
    jstar = ff.generalized_jacobian(scope["model"], scope["Q"])
    assert out[2] == f"{np.mean(np.linalg.det(jstar[:, [0, 1, 6, 7], :]) < 0):.1%} of joint space has det J* < 0"
    # "# paper: 0.230 0.483 0.523": the §V coefficients as printed in the paper
    assert out[3] == "alpha={:.3f} beta={:.3f} gamma={:.3f}".format(*(float(PAPER[f"92.S5.{k}"] or 0) for k in ("alpha", "beta", "gamma")))
    for name in ("alpha", "beta", "gamma"):
        paper_or_documented(f"92.S5.{name}", float(scope[name]))
    # the simulation: the attitude change read from the quaternion, the momentum from H+ (zero: it starts at rest)
    traj = scope["traj"]
    change = re.fullmatch(rf"attitude change {NUMBER} deg, \|h\| = {NUMBER} N m s", out[4])
    assert change, out[4]
    assert float(change[1]) == pytest.approx(np.degrees(Rotation.from_quat(traj.attitude[-1]).as_rotvec()[2]), abs=0.005)
    assert abs(float(change[1])) > 1.0  # the spacecraft does turn in reaction
    h = np.einsum("tij,tj->ti", ff.system_inertia_matrix(scope["model"], traj.q)[:, 3:6, :], traj.velocity)
    assert float(change[2]) < 1e-9 and np.abs(h).max() < 1e-9


# --------------------------------------------------------------------- the docs' code blocks
def _simulation_first(scope: dict[str, Any], tmp_path: Path) -> None:
    """docs/simulation.md's first block: a controlled free-floating run, saved, loaded and plotted."""
    model, traj = scope["model"], scope["traj"]
    # momentum is conserved (joint torques are internal): the initial spin's angular momentum, from H+ at t = 0
    h0 = ff.system_inertia_matrix(model, traj.q[0])[3:6] @ traj.velocity[0]
    np.testing.assert_allclose(traj.angular_momentum, np.tile(Rotation.from_quat(traj.attitude[0]).apply(h0), (len(traj.t), 1)), atol=1e-8)
    assert np.abs(traj.angular_momentum[0, 2]) > 1.0 and np.abs(traj.joint_torque).max() <= 10.0 + 1e-12
    again = ff.Trajectory.load(tmp_path / "run.npz", model=model)
    for name in ("t", "q", "qdot", "attitude", "omega", "joint_torque"):
        np.testing.assert_array_equal(getattr(again, name), getattr(traj, name), err_msg=name)
    lines = plt.gcf().axes[0].get_lines()  # traj.plot(): the joint angles first
    assert len(lines) == model.n_joints
    for k, line in enumerate(lines):
        np.testing.assert_allclose(line.get_xydata(), np.column_stack([traj.t, np.degrees(traj.q[:, k])]))
    np.testing.assert_allclose(traj.q[-1], np.radians([20, 70, 160, -70]), atol=0.05)  # the PD reached its set point


def _simulation_rollout(scope: dict[str, Any], tmp_path: Path) -> None:
    """docs/simulation.md's batched rollout: each trajectory equals ff.simulate run alone with its own gains."""
    model, traj, states = scope["model"], scope["traj"], scope["states"]
    for b in (0, scope["B"] - 1):
        kp = float(np.linspace(5, 50, scope["B"])[b])
        pd = ff.JointPD(kp=kp, kd=10.0, q_ref=0.3)
        alone = ff.simulate(model, ff.State(q=states.q[b]), 2.0, pd, fixed_step=1e-3, sample_period=0.01, output_period=1e-3)
        np.testing.assert_allclose(traj.t, alone.t, atol=1e-12)
        np.testing.assert_allclose(traj.q[:, b], alone.q, atol=1e-9)


def _index(scope: dict[str, Any], tmp_path: Path) -> None:
    """docs/index.md: '# free-floating: momentum stays zero'."""
    traj = scope["traj"]
    assert np.abs(traj.angular_momentum).max() < 1e-9 and np.abs(traj.linear_momentum).max() < 1e-9
    assert np.ptp(traj.spacecraft_euler321[:, 2]) == 0.0 and not np.any(traj.qdot)  # at rest, nothing moves


def _workspaces(scope: dict[str, Any], tmp_path: Path) -> None:
    """docs/workspaces.md: the numbers in its comments, and the paper's (Tables III and VI, §V)."""
    text = (ROOT / "docs" / "workspaces.md").read_text(encoding="utf-8")

    def comment_numbers(call: str) -> list[float]:
        line = next(line for line in text.splitlines() if line.startswith(call))
        return [float(x) for x in re.findall(NUMBER, re.sub(r"\(eq\. \d+\)", "", line.partition("#")[2]))]

    reach = eval('reachable_workspace(two, "arm1_ee")', scope)
    gw = eval('guaranteed_workspace(two, "arm1_ee")', scope)
    piw, plan = scope["piw"], scope["plan"]
    assert comment_numbers("reachable_workspace(") == pytest.approx([reach.R_min, reach.R_max], abs=5e-5)
    assert comment_numbers("guaranteed_workspace(") == pytest.approx([gw.R_min, gw.R_max], abs=5e-5)
    lo, hi = piw.R_min, piw.R_max
    assert comment_numbers("piw = ") == pytest.approx([lo, hi, *piw.piw[0]], abs=5e-5) and piw.piw[0][0] == 0.0
    for key, value in {"92.T3.arm1.R_max": reach.R_max, "92.T3.arm1.GW_min": gw.R_min, "92.T3.arm1.GW_max": gw.R_max}.items():
        paper_or_documented(key, value)
    paper_or_documented("92.T6.PIW_min", lo)
    paper_or_documented("92.T6.PIW_max", hi)
    paper_or_documented("92.S5.R_plus", plan.placement.R_plus)
    paper_or_documented("92.S5.approach_distance", plan.approach_distance)
    paper_or_documented("92.S5.q1_deg", float(np.degrees(plan.posture.q[0])))
    paper_or_documented("92.S5.q2_deg", float(np.degrees(plan.posture.q[1])))
    paper_or_documented("92.S5.theta_deg", float(np.degrees(plan.posture.theta)))


def _impact_planner(scope: dict[str, Any], tmp_path: Path) -> None:
    """docs/impact.md's capture planner with a moving target: the numbers in its comments, and the impact it says."""
    text = (ROOT / "docs" / "impact.md").read_text(encoding="utf-8")

    def comment_numbers(call: str) -> list[float]:
        line = next(line for line in text.splitlines() if line.startswith(call))
        return [float(x) for x in re.findall(NUMBER, line.partition("#")[2].replace("ω0⁺", ""))]

    plan, ranking, model = scope["plan"], scope["ranking"], scope["model"]
    q1, q2, measure, best = comment_numbers("plan.posture.q ")
    assert np.degrees(plan.posture.q) == pytest.approx([q1, q2], abs=5e-3)
    assert plan.posture.measure == pytest.approx(measure, abs=5e-5) and ranking.measure[ranking.planner] == pytest.approx(best, abs=5e-5)
    rate = comment_numbers("plan.impact ")[-1]  # after the call it names
    assert np.linalg.norm(plan.impact.state.omega) == pytest.approx(rate, rel=5e-3)
    direct = ff.capture.impact(model, plan.grasp_state, plan.target, 0, "free")
    np.testing.assert_array_equal(plan.impact.impulse, direct.impulse)
    assert ranking.spacecraft_rate[ranking.planner] == pytest.approx(comment_numbers("ranking.spacecraft_rate ")[0], rel=5e-3)


#: Per docs page, per ```python block in order: what its results must be (None: it runs, its shape comments hold).
DOCS_WITH_CODE: dict[str, list[Callable[[dict[str, Any], Path], None] | None]] = {
    "simulation.md": [_simulation_first, _simulation_rollout],
    "index.md": [_index],
    "workspaces.md": [_workspaces],
    "impact.md": [None, None, _impact_planner, None],
}


@pytest.mark.parametrize("name", list(DOCS_WITH_CODE))
def test_docs_python_blocks_run(name: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The ```python blocks of the docs listed in DOCS_WITH_CODE run as written (in a scratch directory), and their
    results are what the text and the comments say."""
    monkeypatch.chdir(tmp_path)
    path = ROOT / "docs" / name
    blocks = python_blocks(path)
    assert len(blocks) == len(DOCS_WITH_CODE[name]), f"{name} has {len(blocks)} ```python blocks: check each one here"
    scope: dict[str, Any] = {"__name__": "docs"}
    for block, check in zip(blocks, DOCS_WITH_CODE[name], strict=True):
        exec(compile(block, str(path), "exec"), scope)
        check_shape_comments(block, scope)
        if check is not None:
            check(scope, tmp_path)


# --------------------------------------------------------------------- the README's commands, top to bottom
MAKEFILE = ROOT / "Makefile"


def shell_commands() -> list[str]:
    """The command lines of the README's plain ``` blocks, in order, without their comments."""
    lines, fence = [], None  # fence: the language of the open block ("" for a plain one), None outside
    for line in README.read_text(encoding="utf-8").splitlines():
        if line.startswith("```"):
            fence = line[3:].strip() if fence is None else None
            continue
        command = line.split("#", 1)[0].strip()
        if fence == "" and command.startswith(("freefloat ", "make ")):
            lines.append(command)
    return lines


def make_recipe(target: str) -> list[str]:
    """What ``make TARGET`` runs, read from the Makefile (the venv's own ``freefloat``, OUT = out)."""
    text = MAKEFILE.read_text(encoding="utf-8")
    recipe = re.search(rf"^{target}:.*\n((?:\t.*\n)+)", text, flags=re.M)
    assert recipe, f"Makefile has no {target!r} target"
    return [line.strip().replace("$(VENV)/bin/", "").replace("$(OUT)", "out") for line in recipe.group(1).splitlines()]


def table_rows(text: str, header: str) -> list[list[str]]:
    """The rows of the table under the line starting with ``header`` in ``freefloat inspect``'s output, split on 2+ spaces
    outside brackets."""
    lines = text[text.index("\n" + header) + 1 :].splitlines()
    rows = []
    for line in lines[2:]:
        if not line.startswith("  ") or not line.strip()[0].isdigit():
            break
        rows.append(re.split(r"\s{2,}(?![^\[]*\])", line.strip()))
    return rows


def test_readme_commands_run_top_to_bottom(tmp_path: Path) -> None:
    """Every README command against the installed CLI, in a scratch copy of the examples, in the README's order;
    what each prints or writes is checked against the models, the paper and the same quantities computed here.

    ``make demo`` runs its recipe (the venv and install steps are this test environment's own);
    ``make test`` is the suite running this test, so it is the one command not run again.
    """
    cli = Path(sys.executable).parent / "freefloat"
    assert cli.is_file(), f"the installed `freefloat` command is missing next to {sys.executable}: pip install -e ."
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    commands = shell_commands()
    assert commands[:2] == ["make demo", "make test"] and sum(c.startswith("freefloat ") for c in commands) >= 7
    ran = []
    for command in commands:
        if command == "make test":
            continue
        for line in make_recipe("demo") if command == "make demo" else [command]:
            argv = line.split()
            assert argv[0] == "freefloat", line
            result = subprocess.run([str(cli), *argv[1:]], cwd=tmp_path, capture_output=True, text=True, timeout=600)
            assert result.returncode == 0, f"`{line}` failed:\n{result.stderr[-2000:]}"
            ran.append((line, result.stdout))
    outputs = dict(ran)
    out = tmp_path / "out"

    # freefloat kernels: the suite's setting (make test: portable) and the portable kernels this checkout ships, in use
    text = outputs["freefloat kernels"]
    assert "setting: FREEFLOAT_KERNELS=portable" in text, text
    assert re.search(r"^portable kernels: \d+ for numba ", text, flags=re.M), text

    # freefloat inspect papadopoulos1992: Table I's masses; its barycentric vectors are Table II's coefficients
    text = outputs["freefloat inspect papadopoulos1992"]
    assert f"total mass          {TABLE_I_MASS:g} kg" in text and "size                5 bodies, 4 joints, 2 end effectors" in text
    assert "1 end effectors" not in text
    bary = {row[1]: row for row in table_rows(text, "Barycentric vectors")}
    mu = {name: float(row[2]) for name, row in bary.items()}
    assert mu["arm1_link1"] == pytest.approx(70.0 / TABLE_I_MASS, abs=5e-6) and mu["arm1_link2"] == pytest.approx(
        30.0 / TABLE_I_MASS, abs=5e-6
    )
    first = lambda cell: float(cell.strip("[]").split(",")[0])  # noqa: E731  (x of "[x, y, z]")
    # |r*| of arm 1's link 2 joint = β⁽¹⁾, |l*| of arm 2's links = |δ⁽¹⁾|, |ε⁽¹⁾|; the end effector's r* = γ⁽¹⁾
    paper_or_documented("92.T2.arm1.beta", first(bary["arm1_link2"][6]))
    paper_or_documented("92.T2.arm1.delta", first(bary["arm2_link1"][5]))
    paper_or_documented("92.T2.arm1.epsilon", first(bary["arm2_link2"][5]))
    ee = table_rows(text, "End effectors")
    paper_or_documented("92.T2.arm1.gamma", first(ee[0][4]))

    # the URDF: the joints as the file gives them
    urdf = json.loads(outputs["freefloat inspect examples/models/six_dof_arm.urdf --json"])
    assert urdf["n_joints"] == 6 and urdf["n_end_effectors"] == 1 and urdf["joints"][0]["rpy_deg"][2] == 90.0
    root = ElementTree.parse(tmp_path / "examples/models/six_dof_arm.urdf").getroot()
    moving = [j for j in root.iter("joint") if j.get("type") != "fixed"]
    assert [j["name"] for j in urdf["joints"]] == [j.get("name") for j in moving]
    for joint, xml in zip(urdf["joints"], moving, strict=True):
        origin = xml.find("origin")
        assert origin is not None
        np.testing.assert_allclose(joint["origin"], [float(x) for x in origin.get("xyz", "0 0 0").split()], atol=1e-12)
        np.testing.assert_allclose(joint["rpy_deg"], np.degrees([float(x) for x in origin.get("rpy", "0 0 0").split()]), atol=1e-9)
        axis = xml.find("axis")
        assert axis is not None
        np.testing.assert_allclose(joint["axis"], [float(x) for x in axis.get("xyz", "").split()], atol=1e-12)
    # "-e tool0: only tool0 as end effector: J* is 6 x 6"
    text = outputs["freefloat inspect examples/models/six_dof_arm.urdf -e tool0"]
    assert "size                7 bodies, 6 joints, 1 end effector\n" in text and "end effectors       named" in text
    (tool,) = table_rows(text, "End effectors")
    tool_joint = next(j for j in root.iter("joint") if j.find("child").get("link") == "tool0")  # type: ignore[union-attr]
    assert tool[1:3] == ["tool0", tool_joint.find("parent").get("link")]  # type: ignore[union-attr]
    model = ff.load(tmp_path / "examples/models/six_dof_arm.urdf", end_effectors=["tool0"])
    assert ff.generalized_jacobian(model, np.zeros(6)).shape == (6, 6)
    # the built-in models, and ETS-VII's "3 corrections its published inertias need"
    listed = outputs["freefloat inspect"].splitlines()[1:]
    assert [line.split()[0] for line in listed] == list(ff.models.BUILTIN_MODELS)
    assert "corrections         3 (listed below)" in outputs["freefloat inspect ets7"]
    assert len(ff.models.load_model("ets7").corrections) == 3

    # make demo and reproduce 1992: the reports hold the paper's printed numbers and the same computed ones
    demo = {r["id"]: r for r in json.loads((out / "1992/report.json").read_text())["rows"]}
    again = {r["id"]: r for r in json.loads((out / "paper1992/report.json").read_text())["rows"]}
    assert demo.keys() == again.keys()
    for key, row in demo.items():
        printed = PAPER[key.removesuffix(".as_printed").removesuffix(".collinear")]
        assert row["paper"] == (None if printed is None else float(printed)) == again[key]["paper"], key
        assert (row["ours"] is None) == (again[key]["ours"] is None) and row["agrees"] == again[key]["agrees"], key
        if row["ours"] is not None:
            # the same computation; the §V posture is the optimum of a very flat |det J*| (docs/workspaces.md), found
            # by SLSQP to ~1e-5 deg only: two runs may differ in the 6th digit
            assert row["ours"] == pytest.approx(again[key]["ours"], abs=1e-4 if key.endswith("_deg") else 1e-9, rel=1e-9), key
            if key in PAPER:
                paper_or_documented(key, row["ours"])
    assert json.loads((out / "1991/report.json").read_text())["paper"] == "1991"
    assert "1991/report.md" in (out / "README.md").read_text() and "1992/report.md" in (out / "README.md").read_text()
    manifest = json.loads((out / "freefloat-manifest.json").read_text())["files"]
    assert "1992/report.json" in manifest and all(entry["command"] == "demo" for entry in manifest.values())
    for name in ("fig4_two_arm_workspaces.png", "fig6_capture_families.png", "fig7_capture_plan.png", "fig_singularity_maps.png"):
        check_paper_figure(out / "paper1992" / name)

    # freefloat simulate (joint PD, RK4): the CSV is the run ff.simulate makes of the same scenario
    header = (out / "joint_pd/trajectory.csv").read_text().splitlines()[0].split(",")
    rows = np.loadtxt(out / "joint_pd/trajectory.csv", delimiter=",", skiprows=1)

    def column(name: str) -> np.ndarray:
        return rows[:, header.index(name)]

    model = ff.models.papadopoulos1992()
    names = model.joint_names
    q_ref = np.radians([40.0, 60.0, 170.0, -90.0])
    alone = ff.simulate(
        model,
        ff.State(q=np.radians([0.0, 90.0, 180.0, -90.0])),
        10.0,
        ff.JointPD(kp=20.0, kd=30.0, q_ref=q_ref),
        fixed_step=0.002,
        sample_period=0.01,
        output_period=0.02,
        limits=ff.ActuatorLimits(joint_torque=10.0),
    )
    np.testing.assert_allclose(column("t"), alone.t, atol=1e-12)
    np.testing.assert_allclose(np.column_stack([column(f"q[{n}]") for n in names]), alone.q, atol=1e-9)
    np.testing.assert_allclose(np.column_stack([column(f"joint_torque[{n}]") for n in names]), alone.joint_torque, atol=1e-9)
    np.testing.assert_allclose(np.column_stack([column(f"attitude[{c}]") for c in "xyzw"]), alone.attitude, atol=1e-9)
    assert np.abs(alone.joint_torque).max() == pytest.approx(10.0) and np.abs(alone.q[-1] - q_ref).max() < 0.05
    assert np.abs(alone.angular_momentum).max() < 1e-9  # free-floating from rest: "angular momentum stays zero"

    # freefloat workspace (two arms, payload in arm 1): 1992 Table V, with its documented differences
    text = outputs["freefloat workspace papadopoulos1992 --payload-mass 400 --payload-inertia 25"]
    for m, block in enumerate(text.split("\narm")[1:], start=1):
        reach = re.search(rf"R_min  {NUMBER}  R_max  {NUMBER}", block)
        assert reach, block
        paper_or_documented(f"92.T5.arm{m}.R_min", float(reach[1]))
        paper_or_documented(f"92.T5.arm{m}.R_max", float(reach[2]))
        gw = re.search(rf"R'_min {NUMBER}  R'_max {NUMBER}", block)
        if m == 1:
            assert gw, block
            paper_or_documented("92.T5.arm1.GW_min", float(gw[1]))
            paper_or_documented("92.T5.arm1.GW_max", float(gw[2]))
        else:  # Table V prints n/a: arm 2 has no guaranteed workspace
            assert gw is None and "guaranteed (eq. 16)  does not exist" in block and PAPER["92.T5.arm2.GW_max"] is None

    # freefloat capture: the §V example, with its documented differences from the paper
    capture = json.loads((out / "capture/capture.json").read_text())
    paper_or_documented("92.S5.R_plus", capture["R_plus"])
    paper_or_documented("92.S5.approach_distance", capture["approach_distance"])
    paper_or_documented("92.S5.q1_deg", capture["posture"]["q_deg"][0])
    paper_or_documented("92.S5.q2_deg", capture["posture"]["q_deg"][1])
    paper_or_documented("92.S5.theta_deg", capture["posture"]["theta_deg"])
    paper_or_documented("92.T6.PIW_min", capture["piw"]["R_min"])
    paper_or_documented("92.T6.PIW_max", capture["piw"]["R_max"])

    # freefloat campaign: the first 2 runs of the example campaign, stored and summarised; the runs are the capture
    # scenario with the drawn target (its delta-v as freefloat capture computes it: the row's parameters into the scenario)
    line = "freefloat campaign examples/campaigns/tumbling_capture.toml --out out/campaign --max-runs 2"
    assert "2 ok, 0 failed, 0 already stored, of 2 selected (64 planned)" in outputs[line]
    rows = ff.campaigns.read_runs(out / "campaign").to_pylist()
    spec = ff.campaigns.load_campaign(tmp_path / "examples/campaigns/tumbling_capture.toml")
    assert [r["run_id"] for r in rows] == [r.run_id for r in ff.campaigns.plan_runs(spec)[:2]]
    assert "| sequence.detumble.delta_v |" in (out / "campaign/report/summary.md").read_text()
    scenario = ff.scenarios.load_capture_scenario(tmp_path / "examples/scenarios/tumbling_satellite_capture.toml")
    first = rows[0]
    velocity = scenario.angular_velocity.copy()
    velocity[2] = first["payload.angular_velocity[2]"]
    inertia = inertia_matrix(first["payload.inertia"], "payload.inertia")  # Izz of the planar model, as the scenario reads it
    target = dataclasses.replace(scenario, mass=first["payload.mass"], angular_velocity=velocity, inertia=inertia)
    sequence = ff.scenarios.run_capture_scenario(target).sequence
    assert sequence is not None and first["sequence.detumble.delta_v"] == pytest.approx(sequence.cost.delta_v, rel=1e-12)

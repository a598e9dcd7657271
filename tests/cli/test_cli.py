"""The command line: inspect (text, JSON, files, payloads), demo, and one-line errors."""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from typer.testing import CliRunner, Result

import freefloat as ff
from freefloat.cli import app
from freefloat.core.errors import LongRunWarning
from freefloat.papers.paper1991_figures import FIGURE_NAMES as F91_NAMES
from freefloat.papers.paper1992_figures import FIGURE_NAMES as F92_NAMES
from images import check_paper_figure, check_png
from printed_1992 import PAPER

runner = CliRunner()


def invoke(*args: str) -> Result:
    return runner.invoke(app, list(args))


def inspect_json(*args: str) -> dict[str, Any]:
    result = invoke("inspect", *args, "--json")
    assert result.exit_code == 0, result.output
    assert result.stderr == ""
    return json.loads(result.stdout)


def assert_one_line_error(result: Result, *needles: str) -> str:
    assert result.exit_code == 1, result.output
    assert result.stdout == ""
    lines = result.stderr.splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("error: ")
    assert "Traceback" not in result.output
    for needle in needles:
        assert needle in lines[0]
    return lines[0]


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def by_body(info: dict[str, Any], key: str) -> dict[str, Any]:
    return {row["body"]: row[key] for row in info["barycentric"]}


# --------------------------------------------------------------------- inspect
def test_inspect_text_papadopoulos1992() -> None:
    result = invoke("inspect", "papadopoulos1992")
    assert result.exit_code == 0, result.output
    assert result.stderr == ""
    out = result.stdout
    assert out.splitlines()[0] == "papadopoulos1992"
    assert "total mass          540 kg" in out
    assert "planar              yes" in out
    for name in ("arm1_q1", "arm1_q2", "arm2_q1", "arm2_q2", "arm1_ee", "arm2_ee", "spacecraft", "arm2_link2"):
        assert name in out
    for section in ("Joints", "End effectors", "Mass properties", "Barycentric vectors (1992 eqs. 5-9)"):
        assert f"\n{section}\n" in out
    # μ* of arm 1, link 1: (40 + 30) / 540; r* to joint 2 of arm 1: 1 - (40 * 0.5 + 30 * 1) / 540
    row = next(line for line in out.splitlines() if line.split()[:2] == ["1", "arm1_link1"] and "0.12963" in line)
    assert "[0.0925926, 0, 0]" in row
    assert "0.907407" in next(line for line in out.splitlines() if line.split()[:2] == ["2", "arm1_link2"] and "[0.0277778" in line)
    assert "none" in next(line for line in out.splitlines() if line.split()[:2] == ["0", "arm1_q1"])


def test_inspect_lists_the_joints_own_dynamics(tmp_path: Path) -> None:
    model = ff.load("papadopoulos1992", joints={"arm1_q2": {"armature": 0.25, "damping": 1.5}, "arm2_q1": {"friction": 0.4}})
    path = ff.save(model, tmp_path / "rotors.toml")
    out = invoke("inspect", str(path)).stdout
    table = out.split("\nJoint dynamics\n", 1)[1].split("\n\n", 1)[0].splitlines()
    assert table[1].split() == ["1", "arm1_q2", "0.25", "1.5", "0"]
    assert table[2].split() == ["2", "arm2_q1", "0", "0", "0.4"]
    assert len(table) == 4  # header, two joints, the note: the others have none
    info = inspect_json(str(path))
    assert [(j["armature"], j["damping"], j["friction"]) for j in info["joints"]] == [(0, 0, 0), (0.25, 1.5, 0), (0, 0, 0.4), (0, 0, 0)]
    assert "\nJoint dynamics\n" not in invoke("inspect", "papadopoulos1992").stdout


def test_inspect_json_matches_library() -> None:
    info = inspect_json("papadopoulos1992")
    model = ff.models.papadopoulos1992(arms=2)
    bary = ff.barycentric_vectors(model)
    assert info["name"] == "papadopoulos1992"
    assert info["total_mass"] == 540.0
    assert info["is_planar"] is True
    assert [j["name"] for j in info["joints"]] == list(model.joint_names)
    assert [e["name"] for e in info["end_effectors"]] == ["arm1_ee", "arm2_ee"]
    assert [b["name"] for b in info["bodies"]] == list(model.body_names)
    mu = [row["outboard_mass_fraction"] for row in info["barycentric"]]
    np.testing.assert_allclose(mu, bary.outboard_mass_fraction, rtol=1e-15)
    np.testing.assert_allclose(mu, [1.0, 70 / 540, 30 / 540, 70 / 540, 30 / 540], rtol=1e-14)
    for key in ("r_star", "l_star", "c_star", "barycenter"):
        np.testing.assert_allclose([row[key] for row in info["barycentric"]], getattr(bary, key), rtol=1e-15, atol=1e-15)
    r_star = by_body(info, "r_star")
    assert r_star["arm1_link1"] == pytest.approx([0.5, 0.0, 0.0])
    assert r_star["arm2_link1"] == pytest.approx([-0.5, 0.0, 0.0])
    assert r_star["arm1_link2"] == pytest.approx([1.0 - 50.0 / 540.0, 0.0, 0.0])
    np.testing.assert_allclose(info["system_cm_q0"], ff.system_cm(model, np.zeros(4)), atol=1e-15)
    # at q = 0 every link points along +x: link CMs at x = 1, 2 (arm 1) and 0, 1 (arm 2)
    assert info["system_cm_q0"] == pytest.approx([(40 * 1.0 + 30 * 2.0 + 40 * 0.0 + 30 * 1.0) / 540, 0.0, 0.0])
    joint = info["joints"][2]
    assert joint == {
        "index": 2,
        "name": "arm2_q1",
        "type": "revolute",
        "parent": "spacecraft",
        "child": "arm2_link1",
        "origin": [-0.5, 0.0, 0.0],
        "rotation": [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        "rpy_deg": [0.0, 0.0, 0.0],
        "axis": [0.0, 0.0, 1.0],
        "axis_parent": [0.0, 0.0, 1.0],
        "limits": None,
        "limits_deg": None,
        "armature": 0.0,
        "damping": 0.0,
        "friction": 0.0,
    }
    assert info["end_effector_rule"] == "leaves" and info["corrections"] == []
    link2 = info["bodies"][2]
    assert link2["mass"] == 30.0 and link2["cm"] == [0.5, 0.0, 0.0]
    assert link2["principal_moments"] == pytest.approx([30 * 0.05**2 / 2, 2.5, 2.5])
    ee = info["end_effectors"][0]
    assert ee["body"] == "arm1_link2" and ee["point"] == [1.0, 0.0, 0.0]
    np.testing.assert_allclose(ee["r_star"], bary.end_effector_table[0, 2], rtol=1e-15)


def test_inspect_text_and_json_agree_on_every_model() -> None:
    for name, mass in (("papadopoulos1991", 47.0), ("papadopoulos1992-one-arm", 470.0), ("PAPADOPOULOS1992_ONE_ARM", 470.0)):
        info = inspect_json(name)
        assert info["total_mass"] == mass
        text = invoke("inspect", name).stdout
        assert f"{mass:g} kg" in text and info["name"] in text


def test_inspect_toml_and_urdf_files(tmp_path: Path) -> None:
    model = ff.models.papadopoulos1992(arms=2)
    builtin = inspect_json("papadopoulos1992")
    for suffix in ("toml", "urdf"):
        path = ff.save(model, tmp_path / f"robot.{suffix}")
        info = inspect_json(str(path))
        assert info["source"] == str(path)
        assert info["total_mass"] == pytest.approx(540.0)
        assert info["is_planar"] is True
        assert [j["name"] for j in info["joints"]] == list(model.joint_names)
        for key in ("outboard_mass_fraction", "r_star", "c_star"):
            theirs, ours = by_body(info, key), by_body(builtin, key)
            assert set(theirs) == set(ours)
            for body in ours:
                np.testing.assert_allclose(theirs[body], ours[body], atol=1e-12)
        text = invoke("inspect", str(path))
        assert text.exit_code == 0 and str(path) in text.stdout


def test_inspect_with_payload() -> None:
    info = inspect_json("papadopoulos1992-one-arm", "--payload-mass", "400", "--payload-inertia", "25")
    captured = ff.models.papadopoulos1992(arms=1).with_payload(end_effector=0, mass=400.0, inertia=25.0)
    assert info["total_mass"] == pytest.approx(870.0)
    assert info["name"] == captured.name
    np.testing.assert_allclose([r["outboard_mass_fraction"] for r in info["barycentric"]], captured.bary.outboard_mass_fraction)
    np.testing.assert_allclose([r["r_star"] for r in info["barycentric"]], captured.bary.r_star, atol=1e-15)
    assert info["bodies"][2]["mass"] == pytest.approx(430.0)
    (payload,) = info["payloads"]
    assert payload["mass"] == 400.0 and payload["end_effector"] == "arm1_ee"
    assert np.diag(payload["inertia"]) == pytest.approx([25.0, 25.0, 25.0])

    second = inspect_json("papadopoulos1992", "--payload-mass", "400", "--payload-inertia", "10,20,25", "--payload-ee", "arm2_ee")
    assert second["payloads"][0]["end_effector"] == "arm2_ee"
    assert np.diag(second["payloads"][0]["inertia"]) == pytest.approx([10.0, 20.0, 25.0])
    assert by_body(second, "outboard_mass_fraction")["arm2_link2"] == pytest.approx(430.0 / 940.0)
    assert by_body(second, "outboard_mass_fraction")["arm1_link2"] == pytest.approx(30.0 / 940.0)
    by_index = inspect_json("papadopoulos1992", "--payload-mass", "400", "--payload-inertia", "10,20,25", "--payload-ee", "1")
    assert by_index == second

    text = invoke("inspect", "papadopoulos1992-one-arm", "--payload-mass", "400", "--payload-inertia", "25")
    assert "870 kg" in text.stdout and "payload" in text.stdout and "held by arm1_ee" in text.stdout


@pytest.mark.parametrize(
    ("args", "needles"),
    [
        (["--payload-mass", "400"], ["--payload-inertia"]),
        (["--payload-inertia", "25"], ["--payload-mass"]),
        (["--payload-mass", "-1", "--payload-inertia", "25"], ["mass", "positive"]),
        (["--payload-mass", "400", "--payload-inertia", "1,2"], ["--payload-inertia", "1, 3 or 9"]),
        (["--payload-mass", "400", "--payload-inertia", "heavy"], ["--payload-inertia", "heavy"]),
        (["--payload-mass", "400", "--payload-inertia", "25", "--payload-ee", "arm3_ee"], ["arm3_ee", "Did you mean"]),
    ],
)
def test_payload_errors(args: list[str], needles: list[str]) -> None:
    assert_one_line_error(invoke("inspect", "papadopoulos1992", *args), *needles)


# --------------------------------------------------------------------- errors
def test_missing_file(tmp_path: Path) -> None:
    missing = tmp_path / "nothing.toml"
    assert_one_line_error(invoke("inspect", str(missing)), str(missing), "no such model file")
    assert not missing.exists()


def test_directory_is_not_a_model(tmp_path: Path) -> None:
    assert_one_line_error(invoke("inspect", str(tmp_path)), "is not a file")


def test_malformed_toml(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "x"\n[[bodies]\nmass = 1\n', encoding="utf-8")
    line = assert_one_line_error(invoke("inspect", str(bad)), str(bad), "malformed TOML")
    assert "line 2" in line


def test_invalid_model_in_toml(tmp_path: Path) -> None:
    bad = tmp_path / "negative.toml"
    bad.write_text('name = "x"\n[[bodies]]\nname = "bus"\nmass = -3\ninertia = 1\n', encoding="utf-8")
    assert_one_line_error(invoke("inspect", str(bad)), "bodies[0] (bus).mass", "positive")


def test_malformed_urdf(tmp_path: Path) -> None:
    bad = tmp_path / "bad.urdf"
    bad.write_text("<robot name='x'><link name='a'>\n", encoding="utf-8")
    assert_one_line_error(invoke("inspect", str(bad)), "malformed URDF")


def test_unknown_builtin_name_suggests() -> None:
    line = assert_one_line_error(invoke("inspect", "papadopolous1992"), "papadopolous1992", "did you mean", "'papadopoulos1992'")
    assert "papadopoulos1992-one-arm" in line  # lists the built-in names


def test_input_file_is_never_written(tmp_path: Path) -> None:
    model = ff.models.papadopoulos1992(arms=2)
    paths = [ff.save(model, tmp_path / "robot.toml"), ff.save(model, tmp_path / "robot.urdf")]
    before = {p: (sha256(p), p.stat().st_mtime_ns) for p in paths}
    for path in paths:
        assert invoke("inspect", str(path)).exit_code == 0
        assert invoke("inspect", str(path), "--json", "--payload-mass", "400", "--payload-inertia", "25").exit_code == 0
        assert invoke("inspect", str(path), "--payload-mass", "400").exit_code == 1
    assert {p: (sha256(p), p.stat().st_mtime_ns) for p in paths} == before
    assert sorted(tmp_path.iterdir()) == sorted(paths)


# --------------------------------------------------------------------- demo
@pytest.fixture(scope="module")
def demo_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Result]:
    out = tmp_path_factory.mktemp("demo") / "nested" / "out"
    return out, invoke("demo", "--out", str(out))


DEMO_MODELS = (
    "papadopoulos1991",
    "papadopoulos1992",
    "papadopoulos1992_one_arm",
    "papadopoulos1992_one_arm_captured",
    "papadopoulos1992_captured",
)


def test_demo_writes_reports_and_map(demo_run: tuple[Path, Result]) -> None:
    out, result = demo_run
    assert result.exit_code == 0, result.output
    printed = [Path(line) for line in result.stdout.splitlines()]
    png = out / "detJ_map_1992_one_arm_captured.png"
    expected = [out / "models" / f"{slug}.{ext}" for slug in DEMO_MODELS for ext in ("json", "md")]
    head = [*expected, out / "models" / "report.md", png]
    assert printed[: len(head)] == head
    rest = printed[len(head) :]
    for paper in ("1991", "1992"):
        assert out / paper / "report.json" in rest and out / paper / "report.md" in rest
        assert any(p.parent == out / paper and p.suffix == ".png" for p in rest), paper
    assert rest[-1] == out / "README.md"
    assert "1991/report.md" in rest[-1].read_text() and "1992/report.md" in rest[-1].read_text()
    # every file read back: the model reports hold the models' numbers, the paper reports their rows and the
    # paper's printed numbers, the figures are images of the size they were drawn at
    masses = {"papadopoulos1991": ff.models.papadopoulos1991().total_mass, "papadopoulos1992": 540.0, "papadopoulos1992_one_arm": 470.0}
    masses |= {"papadopoulos1992_one_arm_captured": 870.0, "papadopoulos1992_captured": 940.0}  # 1992 Table I, + 400 kg payload
    for slug, mass in masses.items():
        data = json.loads((out / "models" / f"{slug}.json").read_text(encoding="utf-8"))
        assert data["total_mass"] == pytest.approx(mass), slug
        section = (out / "models" / f"{slug}.md").read_text(encoding="utf-8")
        assert f"{data['name']}" in section and "Barycentric vectors" in section, slug
    for paper in ("1991", "1992"):
        report = json.loads((out / paper / "report.json").read_text(encoding="utf-8"))
        table = (out / paper / "report.md").read_text(encoding="utf-8")
        assert report["paper"] == paper and len(report["rows"]) > 20
        for row in report["rows"]:
            assert f"| `{row['id']}` |" in table, row["id"]
    paper_1992 = {r["id"]: r["paper"] for r in json.loads((out / "1992" / "report.json").read_text(encoding="utf-8"))["rows"]}
    for key, printed_text in PAPER.items():  # the paper's numbers, typed from the paper (tests/printed_1992.py)
        assert paper_1992[key] == (None if printed_text is None else float(printed_text)), key
    figures = [path for path in printed if path.suffix == ".png" and path.parent.name in ("1991", "1992")]
    assert sorted(path.name for path in figures) == sorted([*F91_NAMES, *F92_NAMES])
    for path in figures:
        check_paper_figure(path)
    check_png(png, (6.4, 5.6), 200, min_colours=64)  # the det J* map: a colour map


def test_demo_report_mentions_every_model(demo_run: tuple[Path, Result]) -> None:
    out, _ = demo_run
    report = (out / "models" / "report.md").read_text(encoding="utf-8")
    names = {
        "papadopoulos1991",
        "papadopoulos1992",
        "papadopoulos1992_one_arm",
        "papadopoulos1992_one_arm+payload",
        "papadopoulos1992+payload",
    }
    for name in names:
        assert f"## `{name}`" in report
    assert report.count("### Barycentric vectors") == len(DEMO_MODELS)
    assert "detJ_map_1992_one_arm_captured.png" in report


def test_demo_json_equals_inspect(demo_run: tuple[Path, Result]) -> None:
    out, _ = demo_run
    assert json.loads((out / "models" / "papadopoulos1992.json").read_text(encoding="utf-8")) == inspect_json("papadopoulos1992")
    captured = json.loads((out / "models" / "papadopoulos1992_one_arm_captured.json").read_text(encoding="utf-8"))
    assert captured == inspect_json("papadopoulos1992-one-arm", "--payload-mass", "400", "--payload-inertia", "25")
    two_arm = json.loads((out / "models" / "papadopoulos1992_captured.json").read_text(encoding="utf-8"))
    assert two_arm["total_mass"] == pytest.approx(940.0) and two_arm["payloads"][0]["end_effector"] == "arm1_ee"


def test_demo_out_is_a_file(tmp_path: Path) -> None:
    target = tmp_path / "out"
    target.write_text("keep me", encoding="utf-8")
    assert_one_line_error(invoke("demo", "--out", str(target)), "not a directory")
    assert target.read_text(encoding="utf-8") == "keep me"


# --------------------------------------------------------------------- python -m freefloat
def test_python_m_freefloat() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "freefloat", "inspect", "papadopoulos1991"], capture_output=True, text=True, check=False, timeout=120
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[0] == "papadopoulos1991"
    assert "47 kg" in done.stdout and "Barycentric vectors" in done.stdout
    failed = subprocess.run(
        [sys.executable, "-m", "freefloat", "inspect", "no_such_model.urdf"], capture_output=True, text=True, check=False, timeout=120
    )
    assert failed.returncode == 1
    assert failed.stdout == ""
    assert failed.stderr.splitlines() == ["error: no_such_model.urdf: no such model file"]


# ----------------------------------------------------------------------------- inspect: real files (issue 12)
def test_inspect_without_a_model_lists_the_built_in_models() -> None:
    result = invoke("inspect")
    assert result.exit_code == 0, result.output
    for name in ff.models.BUILTIN_MODELS:
        assert name in result.stdout
    listed = json.loads(invoke("inspect", "--json").stdout)["models"]
    assert [m["name"] for m in listed] == list(ff.models.BUILTIN_MODELS)


@pytest.mark.filterwarnings("always::freefloat.core.errors.ModelCorrectionWarning")  # the warning line is what it checks
def test_inspect_shows_joint_types_the_end_effector_rule_and_corrections(tmp_path: Path) -> None:
    from io_files import flawed_urdf  # tests/io_files.py

    path = flawed_urdf(tmp_path)
    result = invoke("inspect", str(path), "-e", "tool")
    assert result.exit_code == 0, result.output
    assert result.stderr.startswith("warning: ") and "l2" in result.stderr and "nearest physical inertia" in result.stderr
    out = result.stdout
    assert "named (only the listed ones)" in out and "prismatic" in out
    assert "Corrections made when loading" in out and "triangle inequality" in out
    result = invoke("inspect", str(path), "--end-effector", "tool", "--json")
    info = json.loads(result.stdout)
    assert [j["type"] for j in info["joints"]] == ["revolute", "prismatic"]
    assert info["joints"][1]["limits"] == [-0.2, 0.3] and info["joints"][1]["limits_deg"] is None
    (fix,) = info["corrections"]
    assert "l2" in fix["where"] and fix["change_kg_m2"] > 0
    assert [e["name"] for e in info["end_effectors"]] == ["tool"]
    assert json.loads(invoke("inspect", str(path), "--json").stdout)["end_effector_rule"] == "leaves"
    assert_one_line_error(invoke("inspect", str(path), "--strict"), "triangle inequality", "strict=False")
    result = invoke("inspect", str(path), "-e", "nope")
    assert result.exit_code == 1 and result.stdout == ""
    assert result.stderr.splitlines()[0].startswith("warning: ")  # the correction is reported before the error
    assert result.stderr.splitlines()[-1].startswith("error: ") and "'nope' is not a body or frame" in result.stderr


def test_inspect_reads_all_three_formats(tmp_path: Path) -> None:
    from io_files import HAND_WRITTEN

    mjcf = tmp_path / "arm.xml"
    mjcf.write_text(HAND_WRITTEN, encoding="utf-8")
    info = inspect_json(str(mjcf))
    assert info["end_effector_rule"] == "leaf sites" and [j["type"] for j in info["joints"]] == ["revolute", "prismatic", "revolute"]
    toml = tmp_path / "arm.toml"
    ff.save(ff.load(mjcf), toml)
    again = inspect_json(str(toml))
    assert [j["name"] for j in again["joints"]] == [j["name"] for j in info["joints"]]
    assert again["total_mass"] == pytest.approx(info["total_mass"], rel=1e-15)


def test_user_errors_passes_other_warnings_through_once() -> None:
    """Only ModelCorrectionWarning becomes a 'warning:' line; any other warning is re-issued, once (no loop)."""
    import warnings

    from freefloat.cli import user_errors

    with pytest.warns(RuntimeWarning, match="something else") as record:
        with user_errors():
            warnings.warn("something else", RuntimeWarning, stacklevel=1)
    assert len(record) == 1


# ----------------------------------------------------------------------------- warnings: one line each (issue 40)
_ROOT = Path(__file__).resolve().parents[2]
_SCENARIO = _ROOT / "examples" / "scenarios" / "papadopoulos1992_joint_pd.toml"
_CAPTURE = _ROOT / "examples" / "scenarios" / "papadopoulos1992_capture.toml"


def _warns_then(module: Any, name: str, category: type[Warning], monkeypatch: pytest.MonkeyPatch, stop: bool = False) -> str:
    """Replace ``module.name`` by a function that warns ``category`` twice (the same message, from library code), then
    calls the original (or, ``stop``, raises a ValueError: the command ends there with its ``error:`` line)."""
    import warnings

    original = getattr(module, name)
    message = f"{category.__name__} from {name}: the plan passes close to a singularity"

    def warning_first(*args: Any, **kwargs: Any) -> Any:
        for _ in range(2):
            warnings.warn(message, category, stacklevel=2)
        if stop:
            raise ValueError(f"{name}: stopped by the test")
        return original(*args, **kwargs)

    monkeypatch.setattr(module, name, warning_first)
    return message


def _one_warning_line(result: Result, message: str) -> None:
    lines = [line for line in result.stderr.splitlines() if "warning" in line.lower()]
    assert lines == [f"warning: {message}"], result.stderr
    assert ".py:" not in result.stderr and "warnings.warn" not in result.stderr, result.stderr


def _commands() -> list[tuple[str, list[str], str, str, bool]]:
    """Each command: (id, argv, module, function it calls, whether the function stops it)."""
    return [
        ("inspect", ["inspect", "papadopoulos1992"], "freefloat.cli", "model_info", False),
        ("specialise", ["specialise", "papadopoulos1992", "--kind", "jstar"], "freefloat.mechanics.specialised", "specialise", True),
        ("workspace", ["workspace", "papadopoulos1992"], "freefloat.analysis.workspace_report", "workspace_limits", True),
        ("demo", ["demo", "--out", "out"], "freefloat.cli", "paper_systems", True),
        ("reproduce", ["reproduce", "1991", "--out", "out"], "freefloat.papers.reproduce", "reproduce_1991", True),
        ("simulate", ["simulate", str(_SCENARIO), "--out", "out"], "freefloat.scenarios.scenario", "estimate_scenario", True),
        ("capture", ["capture", str(_CAPTURE)], "freefloat.scenarios.capture_scenario", "run_capture_scenario", False),
        ("campaign", ["campaign", "spec.toml", "--out", "out"], "freefloat.campaigns", "load_campaign", True),
    ]


@pytest.mark.parametrize(("argv", "module", "name", "stop"), [c[1:] for c in _commands()], ids=[c[0] for c in _commands()])
@pytest.mark.parametrize("category", [ff.NearSingularWarning, LongRunWarning, UserWarning])
@pytest.mark.filterwarnings("always::UserWarning")  # the warning lines are what it checks (else pytest's "error" decides)
def test_every_command_shows_a_warning_as_one_line(
    argv: list[str], module: str, name: str, stop: bool, category: type[Warning], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A freefloat warning (and another library's UserWarning) on any command: one ``warning: ...`` line, once, with no
    source path or line number; the command then goes on (or ends with its one ``error:`` line)."""
    import importlib

    monkeypatch.chdir(tmp_path)
    message = _warns_then(importlib.import_module(module), name, category, monkeypatch, stop)
    result = invoke(*argv)
    _one_warning_line(result, message)
    if stop:
        assert result.exit_code == 1 and result.stderr.splitlines()[-1] == f"error: {name}: stopped by the test", result.output
    else:
        assert result.exit_code == 0, result.output


def test_an_unexpected_warning_in_a_cli_test_fails_it(monkeypatch: pytest.MonkeyPatch) -> None:
    """The suite's ``filterwarnings = error`` reaches the commands CliRunner runs (the CLI's own "always" is appended
    after it): a warning no test declares ends the command with one ``error:`` line and exit 1, so the test fails."""
    import freefloat.cli

    message = _warns_then(freefloat.cli, "model_info", UserWarning, monkeypatch, False)
    result = invoke("inspect", "papadopoulos1992")
    assert result.exit_code == 1 and result.stdout == "", result.output
    assert result.stderr.splitlines() == [f"error: {message}"], result.stderr


def _inspect_flawed(tmp_path: Path, *flags: str, warnings_env: str | None = None) -> subprocess.CompletedProcess[str]:
    """``python FLAGS -m freefloat inspect flawed.urdf`` (a URDF freefloat corrects with a ModelCorrectionWarning) as a
    process, with ``PYTHONWARNINGS`` set to ``warnings_env`` (else unset)."""
    from io_files import flawed_urdf  # tests/io_files.py

    path = flawed_urdf(tmp_path)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONWARNINGS"}
    if warnings_env is not None:
        env["PYTHONWARNINGS"] = warnings_env
    argv = [sys.executable, *flags, "-m", "freefloat", "inspect", str(path), "-e", "tool"]
    return subprocess.run(argv, capture_output=True, text=True, cwd=tmp_path, env=env, timeout=300)


@pytest.mark.parametrize(("flags", "warnings_env"), [(["-W", "error"], None), ([], "error"), (["-W", "error::UserWarning"], None)])
def test_a_warning_the_user_makes_an_error_is_one_error_line(tmp_path: Path, flags: list[str], warnings_env: str | None) -> None:
    """``python -W error -m freefloat ...`` and ``PYTHONWARNINGS=error`` turn a correction into an error: one
    ``error: ...`` line naming it, exit 1, nothing printed on stdout (the user's filters go ahead of the CLI's)."""
    proc = _inspect_flawed(tmp_path, *flags, warnings_env=warnings_env)
    assert proc.returncode == 1, proc.stderr
    assert proc.stdout == ""
    (line,) = proc.stderr.splitlines()
    assert line.startswith("error: ") and "flawed.urdf: link[2] (l2).inertia violates the triangle inequality" in line, line


def test_a_warning_the_user_ignores_is_not_shown(tmp_path: Path) -> None:
    """``-W ignore::UserWarning`` hides the correction's line; without a filter it is one ``warning:`` line."""
    proc = _inspect_flawed(tmp_path, "-W", "ignore::UserWarning")
    said = [line for line in proc.stderr.splitlines() if not line.startswith("freefloat: ")]  # the kernels' notices
    assert proc.returncode == 0 and said == [], proc.stderr
    proc = _inspect_flawed(tmp_path)
    assert proc.returncode == 0, proc.stderr
    (line,) = [line for line in proc.stderr.splitlines() if not line.startswith("freefloat: ")]
    assert line.startswith("warning: ") and "flawed.urdf: link[2] (l2).inertia violates the triangle inequality" in line, line


def test_a_warning_of_the_capture_sequence_is_one_line_on_the_terminal(tmp_path: Path) -> None:
    """``freefloat capture`` as a process (``main()``, Python's own warning display): NearSingularWarning in the plan is
    one ``warning: ...`` line on stderr, without the ``file.py:LINE: NearSingularWarning`` line Python prints."""
    code = (
        "import warnings, freefloat as ff, freefloat.scenarios.capture_scenario as cs\n"
        "run = cs.run_capture_scenario\n"
        "def warned(*a, **k):\n"
        "    warnings.warn('J* is near-singular along the path', ff.NearSingularWarning, stacklevel=2)\n"
        "    return run(*a, **k)\n"
        "cs.run_capture_scenario = warned\n"
        "import sys; sys.argv = ['freefloat', 'capture', sys.argv[1]]\n"
        "from freefloat.cli import main; main()\n"
    )
    proc = subprocess.run([sys.executable, "-c", code, str(_CAPTURE)], capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert proc.returncode == 0, proc.stderr
    lines = [line for line in proc.stderr.splitlines() if "Warning" in line or "warning" in line]
    assert lines == ["warning: J* is near-singular along the path"], proc.stderr

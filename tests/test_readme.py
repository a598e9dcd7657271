"""The README's quickstart runs as written."""

import re
from pathlib import Path

README = Path(__file__).resolve().parents[1] / "README.md"


def python_blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), flags=re.S)


def test_readme_has_a_quickstart():
    assert python_blocks(), "README.md lost its ```python quickstart block"


def test_readme_quickstart_runs(capsys):
    scope = {"__name__": "readme"}  # one scope: the blocks are read top to bottom
    for block in python_blocks():
        exec(compile(block, str(README), "exec"), scope)
    out = capsys.readouterr().out
    assert "alpha=0.230 beta=0.483 gamma=0.523" in out


DOCS_WITH_CODE = ("simulation.md",)


def test_docs_python_blocks_run(tmp_path, monkeypatch):
    """The ```python blocks of the docs listed in DOCS_WITH_CODE run as written (in a scratch directory)."""
    monkeypatch.chdir(tmp_path)
    for name in DOCS_WITH_CODE:
        path = README.parent / "docs" / name
        blocks = re.findall(r"```python\n(.*?)```", path.read_text(encoding="utf-8"), flags=re.S)
        assert blocks, f"{name} has no ```python block"
        scope = {"__name__": "docs"}
        for block in blocks:
            exec(compile(block, str(path), "exec"), scope)


# --------------------------------------------------------------------- the README's commands, top to bottom
MAKEFILE = README.parent / "Makefile"


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


def test_readme_commands_run_top_to_bottom(tmp_path: Path) -> None:
    """Every README command against the installed CLI, in a scratch copy of the examples, in the README's order.

    ``make demo`` runs its recipe (the venv and install steps are this test environment's own);
    ``make test`` is the suite running this test, so it is the one command not run again.
    """
    import json
    import shutil
    import subprocess
    import sys

    cli = Path(sys.executable).parent / "freefloat"
    assert cli.is_file(), f"the installed `freefloat` command is missing next to {sys.executable}: pip install -e ."
    shutil.copytree(README.parent / "examples", tmp_path / "examples")
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
    urdf = json.loads(outputs["freefloat inspect examples/models/six_dof_arm.urdf --json"])
    assert urdf["n_joints"] == 6 and urdf["n_end_effectors"] == 1 and urdf["joints"][0]["rpy_deg"][2] == 90.0
    for path in ("out/README.md", "out/1991/report.json", "out/1992/report.json", "out/paper1992/report.json"):
        assert (tmp_path / path).is_file(), path
    assert (tmp_path / "out/joint_pd/trajectory.csv").is_file() and (tmp_path / "out/capture/capture.json").is_file()
    assert "1 end effectors" not in outputs["freefloat inspect papadopoulos1992"]
    manifest = json.loads((tmp_path / "out" / "freefloat-manifest.json").read_text())["files"]
    assert "1992/report.json" in manifest and all(entry["command"] == "demo" for entry in manifest.values())

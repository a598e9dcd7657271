"""The release: a wheel that works on its own, one version, the licence, the citation and the changelog.

``test_wheel_installs_and_runs_outside_the_checkout`` is what a user who runs ``pip install freefloat``
meets: ``python -m build`` makes the sdist and, from it, the wheel; the wheel goes into a fresh
virtual environment outside the checkout, and the command line and a short script run there from
another folder. A module or a package-data file (a zoo model, ``py.typed``) missing from the wheel,
or an import that works only from the source tree, fails here.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import textwrap
import tomllib
import venv
import zipfile
from pathlib import Path

import pytest

import freefloat as ff

ROOT = Path(__file__).resolve().parents[1]

SCRIPT = textwrap.dedent(
    """
    import json, pathlib, sys
    import numpy as np
    import freefloat as ff

    model = ff.models.load_model("papadopoulos1992")                # built-in model
    zoo = ff.models.load_model("ets7")                               # a zoo model: package data (TOML)
    q = np.random.default_rng(0).uniform(-1.0, 1.0, size=(64, model.n_joints))
    J = ff.generalized_jacobian(model, q)                            # J* of a batch (1992 eq. 14)
    traj = ff.simulate(model, ff.State(q=q[0], qdot=np.full(model.n_joints, 0.1)), 1.0)   # 1 s, free-floating: h kept
    print(json.dumps({
        "file": ff.__file__, "version": ff.__version__, "J_shape": list(J.shape), "zoo_joints": zoo.n_joints,
        "t_end": float(traj.t[-1]), "h_drift": float(np.abs(traj.angular_momentum - traj.angular_momentum[0]).max()),
        "py_typed": (pathlib.Path(ff.__file__).parent / "py.typed").is_file(),
    }))
    """
)


def _run(argv: list[str], cwd: Path, env: dict[str, str], timeout: float = 900) -> subprocess.CompletedProcess[str]:
    result = subprocess.run(argv, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    assert result.returncode == 0, f"`{' '.join(argv)}` failed ({result.returncode}):\n{result.stdout[-3000:]}\n{result.stderr[-3000:]}"
    return result


def test_wheel_installs_and_runs_outside_the_checkout(tmp_path: Path) -> None:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    env["FREEFLOAT_CACHE_DIR"] = str(tmp_path / "cache")  # the installed copy compiles its own kernels
    # a copy of the tracked files: the build sees what a fresh clone holds, nothing built here
    source = tmp_path / "source"
    tracked = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True).stdout.decode().split("\0")
    for name in filter(None, tracked):
        if (ROOT / name).is_file():
            (source / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(ROOT / name, source / name)
    dist = tmp_path / "dist"
    _run([sys.executable, "-m", "build", "--outdir", str(dist), str(source)], cwd=tmp_path, env=env)
    wheels, sdists = sorted(dist.glob("*.whl")), sorted(dist.glob("*.tar.gz"))
    assert [w.name for w in wheels] == [f"freefloat-{ff.__version__}-py3-none-any.whl"], wheels
    assert [s.name for s in sdists] == [f"freefloat-{ff.__version__}.tar.gz"], sdists
    with zipfile.ZipFile(wheels[0]) as wheel:
        names = set(wheel.namelist())
    shipped = {name.removeprefix("src/") for name in tracked if name.startswith("src/freefloat/")}
    assert shipped <= names, f"files of src/freefloat missing from the wheel: {sorted(shipped - names)}"
    assert "freefloat/py.typed" in names
    assert any(n.endswith(".dist-info/licenses/LICENSE") for n in names), "the wheel carries no LICENSE"

    env_dir = tmp_path / "venv"
    venv.create(env_dir, with_pip=True)
    python = env_dir / "bin" / "python"
    _run([str(python), "-m", "pip", "install", "-q", str(wheels[0])], cwd=tmp_path, env=env)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    cli = str(env_dir / "bin" / "freefloat")

    version = _run([cli, "--version"], cwd=elsewhere, env=env).stdout.strip()
    assert version == f"freefloat {ff.__version__}"
    assert _run([str(python), "-m", "freefloat", "--version"], cwd=elsewhere, env=env).stdout.strip() == version
    info = json.loads(_run([cli, "inspect", "papadopoulos1992", "--json"], cwd=elsewhere, env=env).stdout)
    assert info["n_joints"] == 4 and info["n_end_effectors"] == 2

    (elsewhere / "script.py").write_text(SCRIPT, encoding="utf-8")
    out = json.loads(_run([str(python), "script.py"], cwd=elsewhere, env=env).stdout.strip().splitlines()[-1])
    assert Path(out["file"]).is_relative_to(env_dir), f"imported from {out['file']}, not from the fresh environment"
    assert out["version"] == ff.__version__ and out["J_shape"] == [64, 12, 4] and out["zoo_joints"] == ff.models.ets7().n_joints
    assert out["t_end"] == pytest.approx(1.0) and out["h_drift"] < 1e-9 and out["py_typed"]


def test_version_is_single_sourced() -> None:
    """pyproject reads the version from ``freefloat/_version.py``; the citation and the changelog name it."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    assert "version" not in project["project"] and project["project"]["dynamic"] == ["version"]
    assert project["tool"]["hatch"]["version"]["path"] == "src/freefloat/_version.py"
    assert re.fullmatch(r"\d+\.\d+\.\d+", ff.__version__)
    citation = (ROOT / "CITATION.cff").read_text(encoding="utf-8")
    assert re.search(rf"^version: {re.escape(ff.__version__)}$", citation, flags=re.M)
    assert f"## [{ff.__version__}]" in (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")
    assert f"version = {{{ff.__version__}}}" in (ROOT / "README.md").read_text(encoding="utf-8")  # the README's BibTeX


def test_license_and_citation() -> None:
    """The BSD-3-Clause text the project declares, and a citation with the two papers as references."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    assert project["license"] == "BSD-3-Clause" and project["license-files"] == ["LICENSE"]
    text = (ROOT / "LICENSE").read_text(encoding="utf-8")
    assert text.startswith("BSD 3-Clause License") and "Neither the name of the copyright holder" in text
    import yaml  # PyYAML comes with the docs extra (MkDocs reads its configuration with it)

    citation = yaml.safe_load((ROOT / "CITATION.cff").read_text(encoding="utf-8"))
    assert citation["cff-version"] == "1.2.0" and citation["license"] == "BSD-3-Clause" and citation["type"] == "software"
    titles = [ref["title"].lower() for ref in citation["references"]]
    assert titles == [
        "coordinated manipulator/spacecraft motion control for space robotic systems",
        "large payload manipulation by space robots",
    ]
    assert citation["references"][0]["doi"] == "10.1109/ROBOT.1991.131864"


def test_the_old_name_is_gone() -> None:
    """``git grep -i`` of the former name finds only the sentence that says why the name changed (README and
    changelog) and Pinocchio's own class name for a floating root joint, named in one place."""
    old = "free" + "flyer"  # spelled apart so that this file is not itself a hit
    hits = subprocess.run(["git", "grep", "-i", "-n", old], cwd=ROOT, capture_output=True, text=True).stdout.splitlines()
    files = sorted({line.split(":", 1)[0] for line in hits})
    assert files == ["CHANGELOG.md", "README.md", "src/freefloat/io/oracles.py"], hits
    oracle_hits = [line for line in hits if line.startswith("src/")]
    assert len(oracle_hits) == 1 and re.search(r"return pin\.JointModel\w+\(\)$", oracle_hits[0]), oracle_hits

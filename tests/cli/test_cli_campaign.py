"""``freefloat campaign`` refuses bad input with one line: a campaign file's unknown parameter or distribution (the
field named), an output directory holding another campaign or a user's files (nothing overwritten), a scheduler
that does not answer (within 10 s); a damaged part of a resumed campaign (a warning line, moved aside, its runs run again)."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import tomllib
import warnings
from pathlib import Path

import pytest
import tomli_w
from typer.testing import CliRunner

from freefloat.campaigns import campaign_from_dict, plan_runs
from freefloat.campaigns.runner import CONNECT_TIMEOUT
from freefloat.campaigns.store import MANIFEST, CampaignStore
from freefloat.cli import app

ROOT = Path(__file__).resolve().parents[2]
runner = CliRunner()


def write_campaign(folder: Path, name: str, parameters: dict[str, object]) -> Path:
    data = {"scenario": str(ROOT / "examples" / "scenarios" / "papadopoulos1992_joint_pd.toml"), "parameters": parameters}
    path = folder / name
    path.write_text(tomli_w.dumps(data))
    return path


def one_line_error(*args: str | Path) -> str:
    result = runner.invoke(app, ["campaign", *map(str, args)])
    assert result.exit_code == 1, result.output
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
    return lines[0]


def test_unknown_parameter_and_distribution_name_the_field(tmp_path: Path) -> None:
    spec = write_campaign(tmp_path, "a.toml", {"target.mass": {"values": [1.0, 2.0]}})
    line = one_line_error(spec, "--out", tmp_path / "out")
    assert f"{spec}: parameters.target.mass: unknown parameter" in line and "no 'target' in the top" in line
    spec = write_campaign(tmp_path, "b.toml", {"controller.kp": {"distribution": "weibull", "shape": 2.0}})
    line = one_line_error(spec, "--out", tmp_path / "out")
    assert f"{spec}: parameters.controller.kp.distribution: unknown distribution 'weibull'" in line and "uniform" in line
    assert not (tmp_path / "out").exists()


def test_a_directory_of_another_campaign_or_of_the_user_is_refused_and_kept(tmp_path: Path) -> None:
    first = write_campaign(tmp_path, "first.toml", {"controller.kp": {"values": [1.0, 2.0]}})
    second = write_campaign(tmp_path, "second.toml", {"controller.kp": {"values": [1.0, 3.0]}})
    spec = campaign_from_dict(tomllib.loads(first.read_text()), source=str(first), base=tmp_path)
    out = tmp_path / "out"
    CampaignStore.open(out, spec, plan_runs(spec), resume=False).close()
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    for flags in ([], ["--resume"]):
        line = one_line_error(second, "--out", out, *flags)
        assert "holds the results of another campaign" in line and "nothing is overwritten" in line
    assert {p: p.read_bytes() for p in out.rglob("*") if p.is_file()} == before
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep me")
    line = one_line_error(first, "--out", mine, "--resume")
    assert "is not empty and holds no campaign" in line
    assert [p.name for p in mine.iterdir()] == ["notes.txt"] and (mine / "notes.txt").read_text() == "keep me"
    assert not (mine / MANIFEST).exists()


def test_an_unreachable_scheduler_is_one_line_that_states_its_wait(tmp_path: Path) -> None:
    """The refusal says how long it waited (CONNECT_TIMEOUT); that it does not hang is the subprocess's 60 s limit (speed is
    not asserted in a unit test)."""
    with socket.socket() as probe:  # a port that nothing listens on
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    spec = write_campaign(tmp_path, "a.toml", {"controller.kp": {"values": [1.0, 2.0]}})
    command = [
        sys.executable,
        "-m",
        "freefloat",
        "campaign",
        str(spec),
        "--out",
        str(tmp_path / "out"),
        "--scheduler",
        f"tcp://127.0.0.1:{port}",
    ]
    done = subprocess.run(command, capture_output=True, text=True, timeout=60, env={**os.environ, "PYTHONPATH": str(ROOT / "src")})
    assert done.returncode == 1 and done.stdout == ""
    assert done.stderr.splitlines() == [done.stderr.strip()]
    assert done.stderr.startswith(f"error: --scheduler tcp://127.0.0.1:{port}: no Dask scheduler answered within {CONNECT_TIMEOUT:g} s")
    assert not (tmp_path / "out").exists()
    line = one_line_error(spec, "--out", tmp_path / "out", "--scheduler", "localhost")
    assert line == "error: --scheduler localhost: expected a scheduler address such as tcp://127.0.0.1:8786"


@pytest.mark.filterwarnings("always::freefloat.campaigns.store.DamagedStoreWarning")  # its warning line is what it checks
def test_a_damaged_part_is_a_warning_line_moved_aside_and_its_runs_run_again(tmp_path: Path) -> None:
    import numpy as np

    from freefloat.campaigns import read_runs
    from freefloat.campaigns.execute import RunOutcome

    data = {"function": "campaign_runs:marked", "parameters": {"i": {"values": [0, 1, 2]}, "dir": {"values": [str(tmp_path)]}}}
    spec_file = tmp_path / "f.toml"
    spec_file.write_text(tomli_w.dumps({**data, "record": {"scalars": ["square"]}}))
    spec = campaign_from_dict(tomllib.loads(spec_file.read_text()), source=str(spec_file), base=tmp_path)
    plan, out = plan_runs(spec), tmp_path / "out"
    with CampaignStore.open(out, spec, plan, resume=False) as store:
        kept = store.add([RunOutcome(plan[0].run_id, 0, "ok", scalars={"square": 0.0}, seconds=np.pi)])
        damaged = store.add([RunOutcome(r.run_id, r.index, "ok", scalars={"square": 9.0}) for r in plan[1:]])
    assert kept is not None and damaged is not None
    damaged.write_bytes(damaged.read_bytes()[:50])
    with warnings.catch_warnings():  # as a user runs it: no -W filter (pytest's "error" would make the warning an error)
        warnings.resetwarnings()
        result = runner.invoke(app, ["campaign", str(spec_file), "--out", str(out), "--resume", "--workers", "1", "--no-progress"])
    assert result.exit_code == 0, result.output
    lines = [line for line in result.stderr.splitlines() if line.startswith("warning: ")]
    assert len(lines) == 1 and f"{damaged}: is damaged" in lines[0] and "moved to" in lines[0], result.stderr
    assert "2 ok, 0 failed, 1 already stored, of 3 selected" in result.stdout
    assert (out / "damaged" / damaged.name).is_file() and not damaged.exists()
    rows = read_runs(out).to_pylist()
    assert [r["square"] for r in rows] == [0.0, 1.0, 4.0] and rows[0]["seconds"] == np.pi  # the kept run, as it was stored

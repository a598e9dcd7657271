"""Outputs never clobber (issue 11 item 5): ``--out`` refusal, the manifest, ``--overwrite``, ``--out ""``.

Every command that writes files (simulate, workspace, capture, reproduce, demo) writes through
:mod:`freefloat.io.outputs`; these tests run the cheap ones end to end and the helper directly.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from freefloat.cli import app
from freefloat.io.outputs import MANIFEST, check_targets, staged_outputs

EXAMPLES = Path(__file__).parents[2] / "examples"

SCENARIO = (
    'model = "papadopoulos1992"\nduration = 0.1\n[initial]\nq = [0.1, 0.2, 0.3, 0.4]\n'
    '[integrator]\nmethod = "RK4"\nfixed_step = 0.01\n[outputs]\nplots = false\n'
)


def invoke(*args: str):
    return CliRunner().invoke(app, list(args))


def digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def tree(folder: Path) -> dict[str, str]:
    return {p.relative_to(folder).as_posix(): digest(p) for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture
def scenario(tmp_path: Path) -> Path:
    path = tmp_path / "scen.toml"
    path.write_text(SCENARIO)
    return path


@pytest.mark.parametrize(
    "args",
    [
        ["simulate", "SCEN", "--out", ""],
        ["reproduce", "1991", "--out", ""],
        ["demo", "--out", ""],
        ["workspace", "papadopoulos1992", "--out", ""],
        ["capture", str(EXAMPLES / "scenarios" / "papadopoulos1992_capture.toml"), "--out", ""],
    ],
    ids=lambda a: a[0],
)
def test_empty_out_is_an_error(args: list[str], scenario: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "trajectory.csv").write_text("precious\n")
    before = tree(tmp_path)
    result = invoke(*[str(scenario) if a == "SCEN" else a for a in args])
    assert result.exit_code == 1, result.output
    lines = [line for line in result.output.splitlines() if line.startswith("error:")]
    assert len(lines) == 1 and "empty path" in lines[0] and "--out" in lines[0]
    assert tree(tmp_path) == before  # nothing written into the current directory


def test_simulate_refuses_a_file_it_would_replace(scenario: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    mine = out / "trajectory.csv"
    mine.write_text("my own data\n")
    for extra in ([], ["--overwrite"]):  # not in a manifest: never replaced, even with --overwrite
        result = invoke("simulate", str(scenario), "--out", str(out), "--no-progress", *extra)
        assert result.exit_code == 1
        assert "trajectory.csv" in result.output and "nothing was run" in result.output
        assert ("not written by freefloat" in result.output) == bool(extra)
        assert mine.read_text() == "my own data\n" and sorted(p.name for p in out.iterdir()) == ["trajectory.csv"]


def test_rerun_needs_overwrite_and_replaces_only_manifest_files(scenario: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    first = invoke("simulate", str(scenario), "--out", str(out), "--no-progress")
    assert first.exit_code == 0, first.output
    manifest = json.loads((out / MANIFEST).read_text())["files"]
    assert set(manifest) == {"trajectory.json", "trajectory.npz", "trajectory.csv", "trajectory.csv.json"}
    assert all(manifest[name]["sha256"] == digest(out / name) for name in manifest)
    notes = out / "notes.txt"
    notes.write_text("user notes\n")
    before = tree(out)

    again = invoke("simulate", str(scenario), "--out", str(out), "--no-progress")
    assert again.exit_code == 1 and "--overwrite" in again.output and tree(out) == before

    scenario.write_text(SCENARIO.replace("duration = 0.1", "duration = 0.2"))
    replaced = invoke("simulate", str(scenario), "--out", str(out), "--no-progress", "--overwrite")
    assert replaced.exit_code == 0, replaced.output
    after = tree(out)
    assert after["notes.txt"] == before["notes.txt"]  # not an output: untouched
    assert after["trajectory.json"] != before["trajectory.json"]  # the outputs of the first run: replaced
    assert json.loads((out / "trajectory.json").read_text())["t_end"] == pytest.approx(0.2)
    manifest = json.loads((out / MANIFEST).read_text())["files"]
    assert manifest["trajectory.json"]["sha256"] == after["trajectory.json"] and "notes.txt" not in manifest
    assert not list(out.glob(".freefloat-staging-*"))


def test_a_manifest_file_the_user_changed_is_not_replaced(scenario: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    assert invoke("simulate", str(scenario), "--out", str(out), "--no-progress").exit_code == 0
    edited = out / "trajectory.csv"
    edited.write_text(edited.read_text() + "# my annotation\n")
    before = tree(out)
    result = invoke("simulate", str(scenario), "--out", str(out), "--no-progress", "--overwrite")
    assert result.exit_code == 1 and "changed after freefloat wrote it" in result.output
    assert tree(out) == before


def test_workspace_outputs_are_checked_when_the_run_ends(tmp_path: Path) -> None:
    """Names known only after the run (plots per end effector): the staged files are checked at commit."""
    out = tmp_path / "ws"
    out.mkdir()
    plot = out / "workspace_papadopoulos1992_one_arm_arm1_ee.png"
    plot.write_bytes(b"not a png of ours")
    result = invoke("workspace", "papadopoulos1992-one-arm", "--out", str(out), "--no-piw")
    assert result.exit_code == 1 and "outputs were discarded" in result.output and plot.name in result.output
    assert sorted(p.name for p in out.iterdir()) == [plot.name] and plot.read_bytes() == b"not a png of ours"


def test_staged_outputs_helper(tmp_path: Path) -> None:
    out = tmp_path / "o"
    with staged_outputs(out, overwrite=False, command="test") as target:
        (target.stage / "sub").mkdir()
        (target.stage / "sub" / "a.txt").write_text("1")
    assert (out / "sub" / "a.txt").read_text() == "1" and target.final([target.stage / "sub" / "a.txt"]) == [out / "sub" / "a.txt"]
    with pytest.raises(FileExistsError, match=r"sub/a\.txt exists"):
        check_targets(out, ["sub/a.txt"], overwrite=False)
    check_targets(out, ["sub/a.txt", "new.txt"], overwrite=True)  # listed and unchanged: may be replaced
    with pytest.raises(RuntimeError), staged_outputs(out, overwrite=True, command="test") as target:
        (target.stage / "sub").mkdir()
        (target.stage / "sub" / "a.txt").write_text("2")
        raise RuntimeError("the run failed")
    assert (out / "sub" / "a.txt").read_text() == "1"  # a failed run commits nothing
    with pytest.raises(ValueError, match="empty path"), staged_outputs("", overwrite=False, command="test"):
        pass


def test_a_manifest_above_the_output_directory_vouches_for_its_files(tmp_path: Path) -> None:
    """What `demo --out out` wrote into out/1992 may be replaced by `reproduce 1992 --out out/1992 --overwrite`."""
    out = tmp_path / "out"
    with staged_outputs(out, overwrite=False, command="demo") as target:
        (target.stage / "1992").mkdir()
        (target.stage / "1992" / "report.json").write_text("{}")
    inner = out / "1992"
    with pytest.raises(FileExistsError, match="exists"):
        check_targets(inner, ["report.json"], overwrite=False)
    with staged_outputs(inner, overwrite=True, command="reproduce 1992") as target:
        (target.stage / "report.json").write_text('{"new": 1}')
        (target.stage / "extra.png").write_text("png")
    outer = json.loads((out / MANIFEST).read_text())["files"]
    assert outer["1992/report.json"]["sha256"] == digest(inner / "report.json")  # one entry per file, kept up to date
    assert set(json.loads((inner / MANIFEST).read_text())["files"]) == {"extra.png"}
    with staged_outputs(out, overwrite=True, command="demo") as target:  # and the demo again over both
        (target.stage / "1992").mkdir()
        (target.stage / "1992" / "report.json").write_text("{}")
        (target.stage / "1992" / "extra.png").write_text("png2")
    assert (inner / "extra.png").read_text() == "png2"


def test_reproduce_never_replaces_a_user_file(tmp_path: Path) -> None:
    out = tmp_path / "r"
    out.mkdir()
    notes = out / "report.md"
    notes.write_text("my notes on the paper\n")
    result = invoke("reproduce", "1991", "--out", str(out), "--overwrite")  # even with --overwrite: not a file freefloat wrote
    assert result.exit_code == 1 and "report.md was not written by freefloat" in result.output and "nothing was run" in result.output
    assert notes.read_text() == "my notes on the paper\n" and sorted(p.name for p in out.iterdir()) == ["report.md"]


@pytest.mark.parametrize("out", ["user.txt/", "user.txt/sub/", "user.txt/../out"])
def test_simulate_refuses_an_out_it_cannot_make_before_anything_else(out: str, scenario: Path, tmp_path: Path) -> None:
    """A path through a file: one ``error: --out ...`` line, before the run's estimate is even printed; nothing made."""
    (tmp_path / "user.txt").write_text("mine")
    before = tree(tmp_path)
    result = invoke("simulate", str(scenario), "--out", str(tmp_path / out))
    assert result.exit_code == 1, result.output
    assert result.stderr.splitlines() == [result.stderr.strip()] and result.stderr.startswith("error: --out "), result.stderr
    assert tree(tmp_path) == before and sorted(p.name for p in tmp_path.iterdir()) == sorted(["user.txt", scenario.name])


def test_checking_an_out_folder_leaves_no_folder_behind(tmp_path: Path) -> None:
    """check_targets tries to make the folder (and its parents) and removes what it made: the run makes them."""
    check_targets(tmp_path / "a" / "b" / "c", ["trajectory.json"], overwrite=False)
    assert list(tmp_path.iterdir()) == []


def test_an_existing_out_that_cannot_be_written_is_refused_before_the_run(scenario: Path) -> None:
    """``--out /proc`` exists and is a folder, but nothing can be made in it: one ``--out`` line before the estimate
    (was: the estimate printed, then ``[Errno 2] ... '/proc/.freefloat-staging-...'``)."""
    result = invoke("simulate", str(scenario), "--out", "/proc")
    assert result.exit_code == 1 and result.stdout == "", result.output
    assert result.stderr.splitlines() == [
        "error: --out /proc: cannot write here (No such file or directory); choose a folder you can write to"
    ]
    with pytest.raises(OSError, match=r"^--out /proc: cannot write here \(No such file or directory\)"):
        check_targets(Path("/proc"), ["trajectory.json"], overwrite=False)
    with pytest.raises(OSError, match=r"^--out /proc: cannot write here"), staged_outputs("/proc", overwrite=False, command="test"):
        raise AssertionError("the block ran")


def test_an_out_through_dotdot_makes_only_the_folder_it_names(tmp_path: Path) -> None:
    """``--out n/../m`` is the folder m: checking it leaves nothing, the run makes m and no n."""
    check_targets(tmp_path / "n" / ".." / "m", ["a.txt"], overwrite=False)
    assert list(tmp_path.iterdir()) == []
    with staged_outputs(tmp_path / "n" / ".." / "m", overwrite=False, command="test") as out:
        (out.stage / "a.txt").write_text("x")
    assert sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*")) == ["m", "m/a.txt", f"m/{MANIFEST}"]


def test_only_the_folders_this_process_made_are_removed(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Another process makes ``a`` between this one's look and its mkdir: ``a`` is theirs and stays; ``a/b`` is removed."""
    import os

    import freefloat.io.outputs as outputs

    real = os.mkdir

    def raced(path: Any, *args: Any) -> None:
        if Path(path) == tmp_path / "a":
            real(path)  # the other process, first
        real(path, *args)

    monkeypatch.setattr(outputs.os, "mkdir", raced)
    check_targets(tmp_path / "a" / "b", ["a.txt"], overwrite=False)
    assert [p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*")] == ["a"]


def test_a_broken_link_on_the_way_to_out_is_named(tmp_path: Path) -> None:
    """``--out dl/sub`` through a broken link (a chain of two): the message names the link and the target it misses."""
    (tmp_path / "dl").symlink_to(tmp_path / "gone" / "x")
    (tmp_path / "dl2").symlink_to("dl")
    for link in ("dl", "dl2"):
        out = tmp_path / link / "sub"
        with pytest.raises(OSError, match=rf"^--out {out}: {tmp_path / link} is a symbolic link to {tmp_path}/gone/x, which does not"):
            check_targets(out, ["a.txt"], overwrite=False)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dl", "dl2"]


def test_out_expands_the_home_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    monkeypatch.chdir(tmp_path)  # where a "~" folder would be made if it were not expanded
    with staged_outputs("~/results", overwrite=False, command="test") as out:
        (out.stage / "a.txt").write_text("x")
    assert (tmp_path / "home" / "results" / "a.txt").read_text() == "x" and out.path == tmp_path / "home" / "results"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["home"]


def test_capture_checks_out_before_it_estimates_and_asks(tmp_path: Path) -> None:
    """A capture sequence estimated over a minute, with an ``--out`` that cannot be written: the ``--out`` line, before
    the estimate is printed or confirmation asked (as simulate)."""
    text = (EXAMPLES / "scenarios" / "tumbling_satellite_capture.toml").read_text()
    scenario = tmp_path / "long.toml"
    scenario.write_text(text.replace("duration = 30.0", "duration = 1e5", 1))
    (tmp_path / "user.txt").write_text("mine")
    for out, match in ((str(tmp_path / "user.txt"), "exists and is not a directory"), ("/proc", "cannot write here")):
        result = invoke("capture", str(scenario), "--out", out)
        assert result.exit_code == 1, result.output
        (line,) = result.stderr.splitlines()
        assert line.startswith(f"error: --out {out}: {match}"), line
    result = invoke("capture", str(scenario), "--out", str(tmp_path / "out"))  # a good --out: then the estimate
    assert result.exit_code == 1 and "estimated to take over 60 s" in result.stderr and "pass --yes" in result.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["long.toml", "user.txt"]

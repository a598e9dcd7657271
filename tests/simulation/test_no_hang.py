"""Nothing hangs (issue "What a user still meets", item 1), and outputs are checked before the work (item 5).

The issue's cases: ``ff.simulate(model, state, 1.0, lambda t, s: np.full(4, 1e12))`` with the default
adaptive integrator never left t = 0 (the steps shrank to follow joints spinning at 1e11 rad/s);
``freefloat simulate`` of a 1e12 s scenario killed from outside left a staging folder behind;
``--animate /proc/x.gif`` failed after the run; ``demo --out D`` over an earlier run computed
before refusing; a failed run left its empty ``--out`` folder.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import freefloat as ff
from freefloat.cli import app
from freefloat.io.outputs import staged_outputs
from freefloat.simulation._guard import MAX_RATE

ROOT = Path(__file__).parents[2]
SCENARIO = ROOT / "examples" / "scenarios" / "papadopoulos1992_joint_pd.toml"


BEYOND = r"left what the model can mean .* joint 'arm\d_q\d' moves at .* beyond 10000 rad/s"
DIVERGED = r"diverged at t = .* joint 'arm\d_q\d' turns at .* lower the gains"


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({}, BEYOND),
        ({"method": "LSODA"}, BEYOND),
        ({"method": "RK45"}, BEYOND),
        ({"fixed_step": 1e-3}, DIVERGED),
        ({"sample_period": 0.01}, DIVERGED),
    ],
)
def test_a_torque_beyond_meaning_stops_every_integrator_at_once(options: dict[str, float], message: str) -> None:
    """Adaptive integrators without a sample period: the rate bound; a sampled or fixed-step run: the growth test first."""
    model = ff.models.papadopoulos1992()
    with pytest.raises(ff.SimulationError, match=message) as info:
        ff.simulate(model, ff.State(q=[0.1, 0.2, 0.3, 0.4]), 1.0, lambda t, s: np.full(4, 1e12), **options)
    traj = info.value.trajectory
    assert traj is not None and traj.status == "failed" and traj.t[-1] < 0.02  # stopped at once, not at the end


def test_a_spacecraft_spin_beyond_meaning_stops_a_free_floating_run() -> None:
    model = ff.models.papadopoulos1992()
    with pytest.raises(ff.SimulationError, match=r"the spacecraft moves at .* rad/s, beyond 10000"):
        ff.simulate(model, ff.State(q=[0.1, 0.2, 0.3, 0.4], omega=[0.0, 0.0, 2 * MAX_RATE]), 1.0)


def test_fast_but_physical_rates_run_to_the_end() -> None:
    """A reaction-wheel-like joint at 600 rad/s (5,700 rpm) is far below the bound: the run finishes."""
    model = ff.models.papadopoulos1992()
    traj = ff.simulate(model, ff.State(q=[0.1, 0.2, 0.3, 0.4], qdot=[0.0, 0.0, 0.0, 600.0]), 0.05, fixed_step=1e-5)
    assert traj.status == "finished" and abs(traj.t[-1] - 0.05) < 1e-12


@pytest.mark.parametrize("guard", [True, False])
def test_the_wall_clock_budget_ends_a_run_with_what_it_computed(guard: bool) -> None:
    model = ff.models.papadopoulos1992()
    slow = ff.State(q=[0.1, 0.2, 0.3, 0.4])
    with pytest.raises(ff.SimulationError, match=r"used its wall-clock budget of .* Pass max_wall_time") as info:
        ff.simulate(model, slow, 1e6, lambda t, s: -s.qdot, max_wall_time=0.2, divergence_guard=guard, warn_after=None)
    traj = info.value.trajectory
    assert traj is not None and traj.status == "failed" and 0.0 < traj.t[-1] < 1e6


@pytest.mark.parametrize("bad", ["fast", -1.0, 0.0, float("nan")])
def test_max_wall_time_is_checked(bad: object) -> None:
    with pytest.raises(ValueError, match="max_wall_time"):
        ff.simulate(ff.models.papadopoulos1992(), ff.State(q=[0.1, 0.2, 0.3, 0.4]), 1.0, max_wall_time=bad)


def test_a_killed_cli_run_writes_what_it_computed_and_leaves_no_staging_folder(tmp_path: Path) -> None:
    """SIGTERM (kill, a batch system's time limit) ends ``freefloat simulate`` as Ctrl-C does."""
    long = tmp_path / "long.toml"
    long.write_text(SCENARIO.read_text().replace("duration = 10.0", "duration = 1e12"))
    out = tmp_path / "out"
    cli = Path(sys.executable).parent / "freefloat"
    proc = subprocess.Popen([str(cli), "simulate", str(long), "--out", str(out), "--yes"], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120
    while not any(out.glob(".freefloat-staging-*")) and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.05)
    time.sleep(3.0)  # into the run (the staging folder is made just before it starts)
    proc.send_signal(signal.SIGTERM)
    _, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 130, stderr.decode()[-2000:]
    assert sorted(p.name for p in out.iterdir()) == [
        "freefloat-manifest.json", "trajectory.csv", "trajectory.csv.json", "trajectory.json", "trajectory.npz", "trajectory.png",
        "trajectory_momentum.png",
    ]  # fmt: skip
    assert b"interrupted" in stderr and b"Traceback" not in stderr


def test_a_staging_folder_of_a_dead_process_is_removed_by_the_next_run(tmp_path: Path) -> None:
    import socket

    host = socket.gethostname().replace("-", "_")
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True, check=True)
    stale = tmp_path / f".freefloat-staging-{dead.stdout.strip()}@{host}-abc123"
    stale.mkdir()
    (stale / "half_written.csv").write_text("t\n0\n")
    mine = tmp_path / f".freefloat-staging-{os.getpid()}@{host}-live"  # a running process's folder stays
    mine.mkdir()
    other_host = tmp_path / f".freefloat-staging-{dead.stdout.strip()}@another_host-x"  # a shared disk: not ours to judge
    other_host.mkdir()
    with staged_outputs(tmp_path, overwrite=False, command="test") as target:
        (target.stage / "a.txt").write_text("a")
    assert not stale.exists() and mine.exists() and other_host.exists() and (tmp_path / "a.txt").is_file()


def test_a_failed_run_removes_the_folders_it_created(tmp_path: Path) -> None:
    out = tmp_path / "new" / "deeper"
    with pytest.raises(RuntimeError, match="boom"), staged_outputs(out, overwrite=False, command="test"):
        raise RuntimeError("boom")
    assert not (tmp_path / "new").exists()
    (tmp_path / "kept").mkdir()
    with pytest.raises(RuntimeError), staged_outputs(tmp_path / "kept", overwrite=False, command="test"):
        raise RuntimeError("boom")
    assert (tmp_path / "kept").is_dir()  # it was there before: kept


@pytest.mark.parametrize(
    ("animate", "message"),
    [
        ("/proc/x.gif", r"--animate /proc/x.gif: cannot write into /proc"),
        ("movie.avi", r"unknown animation type '.avi'"),
        ("exists.gif", r"exists; freefloat never overwrites"),
    ],
)
def test_animation_target_is_checked_before_the_run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, animate: str, message: str) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "exists.gif").write_bytes(b"GIF89a")
    result = CliRunner().invoke(app, ["simulate", str(SCENARIO), "--out", "out", "--animate", animate])
    assert result.exit_code == 1 and result.output.startswith("error: ") and "Traceback" not in result.output
    assert __import__("re").search(message, result.output), result.output
    assert not (tmp_path / "out").exists() and "steps" not in result.output  # refused before the estimate and the run


def test_mp4_without_ffmpeg_is_refused_before_the_run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from matplotlib import animation

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(animation.FFMpegWriter, "isAvailable", classmethod(lambda cls: False))
    result = CliRunner().invoke(app, ["simulate", str(SCENARIO), "--out", "out", "--animate", "run.mp4"])
    assert result.exit_code == 1 and "needs ffmpeg, which is not installed" in result.output and not (tmp_path / "out").exists()


@pytest.mark.parametrize("command", [["demo"], ["reproduce", "1991"], ["reproduce", "1992"]])
def test_an_earlier_run_is_refused_before_the_work(tmp_path: Path, command: list[str], monkeypatch: pytest.MonkeyPatch) -> None:
    """The names a command will write are checked before it computes: no paper is reproduced to be thrown away."""
    from freefloat.papers import reproduce

    out = tmp_path / "out"
    folder = out / command[1] if command[0] == "reproduce" else out / "1992"
    folder.mkdir(parents=True)
    (folder / "report.json").write_text("{}")  # an earlier run's report (or the user's file)

    def fail(*args: object, **kwargs: object) -> None:
        raise AssertionError("the work started")

    monkeypatch.setattr(reproduce, "compute_1991", fail)
    monkeypatch.setattr(reproduce, "compute_1992", fail)
    target = ["--out", str(folder)] if command[0] == "reproduce" else ["--out", str(out)]
    result = CliRunner().invoke(app, [*command, *target])
    assert result.exit_code == 1 and "nothing was run" in result.output, result.output
    assert not list(out.rglob(".freefloat-staging-*"))


def test_a_python_controlled_rollout_beyond_meaning_fails_with_what_it_computed() -> None:
    """It used to finish with NaN states and status "finished"; now it stops as simulate does (a joint's angle beyond
    1e4 rad is fine: a wheel turns for ever; its rate is what the bound is about)."""
    model = ff.models.papadopoulos1992()
    states = ff.State(q=np.zeros((3, 4)))
    with pytest.raises(ff.SimulationError, match=r"trajectory 0 of the rollout became non-finite or moves beyond 10000 rad/s") as info:
        ff.rollout(model, states, 1.0, dt=0.01, controller=lambda t, s: np.full((3, 4), 1e12))
    assert info.value.trajectory is not None and info.value.trajectory.status == "failed"
    spinning = ff.rollout(
        model, ff.State(q=np.full((2, 4), 2e4), qdot=np.full((2, 4), 50.0)), 0.05, dt=1e-3, controller=lambda t, s: 0 * s.q
    )
    assert spinning.status == "finished" and np.isfinite(spinning.q).all()


def test_an_interrupt_inside_a_record_leaves_a_whole_trajectory() -> None:
    """Ctrl-C or SIGTERM between the appends of the recorder (a time without its state) leaves the records whole."""
    from freefloat.core.state import pack_state
    from freefloat.simulation._integrate import _Recorder

    model = ff.models.papadopoulos1992()
    x = pack_state(ff.State(q=[0.1, 0.2, 0.3, 0.4]).resolve(model), None)
    act = (np.zeros(4), np.zeros(3), np.zeros(3), np.array(False))
    rec = _Recorder(model)
    rec.add(0.0, x, act)
    rec.add(0.1, x, act)
    rec.t.append(0.2)  # the interrupt came after the time was appended
    traj = rec.trajectory("interrupted")
    assert traj.t.tolist() == [0.0, 0.1] and traj.q.shape == (2, 4) and traj.joint_torque.shape == (2, 4)

"""Memory is checked before it is taken (issue "What a user still meets", item 2): every sampling, map and batch call
estimates its peak memory and refuses, with the estimate and the way out, what would not fit; no MemoryError."""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

import freefloat as ff
from freefloat.cli import app
from freefloat.core.errors import MemoryBudgetError
from freefloat.core.resources import available_memory, format_bytes, require_memory


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: ff.workspace.jacobian_determinant_map(ff.models.papadopoulos1992(), n=100_000), r"a map of 100000 x 100000"),
        (lambda: ff.workspace.reachable_workspace(ff.models.spacecraft_7dof(), 0, samples=10**9), r"sampling 1.07e\+09 configurations"),
        (
            lambda: ff.workspace.path_independent_workspace(ff.models.papadopoulos1992(), 0, samples=10**9),
            r"sampling 1e\+09 configurations",
        ),
        (lambda: ff.workspace.workspace_cloud(ff.models.spacecraft_7dof(), 0, samples=10**10), r"sampling .* configurations"),
        (
            lambda: ff.rollout(ff.models.papadopoulos1992(), ff.State(q=np.zeros((10_000, 4))), 1000.0, dt=1e-3),
            r"a rollout of 10000 trajectories",
        ),
    ],
)
def test_huge_sampling_and_maps_are_refused_up_front(call: object, message: str, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("FREEFLOAT_MEMORY_LIMIT", "16G")  # the same answer on a machine with more memory free
    with pytest.raises(MemoryBudgetError, match=message + r".* would need about .* more than this machine has free .*; "):
        call()  # type: ignore[operator]


def test_a_batch_whose_result_does_not_fit_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("FREEFLOAT_MEMORY_LIMIT", "100M")
    q = np.broadcast_to(np.zeros(4), (2_000_000, 4))  # a view: no memory; J* would be 2e6 x 12 x 4 doubles = 768 MB
    with pytest.raises(
        MemoryBudgetError, match=r"a result of shape \(2000000, 12, 4\) would need about 768 MB .* pass fewer configurations"
    ):
        ff.generalized_jacobian(ff.models.papadopoulos1992(), q)
    assert ff.generalized_jacobian(ff.models.papadopoulos1992(), q[:1000]).shape == (1000, 12, 4)  # what fits runs


def test_the_cli_prints_one_line(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("FREEFLOAT_MEMORY_LIMIT", "16G")
    result = CliRunner().invoke(app, ["workspace", "papadopoulos1992", "--samples", "1000000000"])
    assert result.exit_code == 1 and result.output.startswith("error: sampling 1e+09 configurations along lines would need about")
    assert len(result.output.splitlines()) == 1


def test_the_budget_reads_the_machine_or_the_variable(monkeypatch: pytest.MonkeyPatch) -> None:
    assert (available_memory() or 0) > 1 << 28
    monkeypatch.setenv("FREEFLOAT_MEMORY_LIMIT", "2G")
    assert available_memory() == 2 << 30
    require_memory(1.5e9, "x", "y")  # 1.5 GB <= 0.8 x 2 GiB: allowed
    with pytest.raises(MemoryBudgetError, match=r"^x would need about 1.8 GB of memory, more than this machine has free \(2.15 GB\); y$"):
        require_memory(1.8e9, "x", "y")
    monkeypatch.setenv("FREEFLOAT_MEMORY_LIMIT", "lots")
    with pytest.raises(MemoryBudgetError, match="FREEFLOAT_MEMORY_LIMIT='lots': expected bytes"):
        require_memory(1e9, "x", "y")
    assert format_bytes(3.2e9) == "3.2 GB" and format_bytes(12) == "12 B"


def test_a_simulation_stops_recording_before_the_memory_runs_out(monkeypatch: pytest.MonkeyPatch) -> None:
    """simulate records as it goes (a 1e12 s run allocates nothing up front); past the free memory it stops with what it has."""
    monkeypatch.setenv("FREEFLOAT_MEMORY_LIMIT", "50M")
    model = ff.models.papadopoulos1992()
    with pytest.raises(ff.SimulationError, match=r"has recorded 65,535 states .* would exceed the memory this machine has free") as info:
        ff.simulate(model, ff.State(q=[0.1, 0.2, 0.3, 0.4], qdot=[0.1, 0, 0, 0]), 100.0, fixed_step=1e-4, output_period=1e-4)
    assert info.value.trajectory is not None and len(info.value.trajectory) == 65_535


def test_a_container_limit_counts(monkeypatch: pytest.MonkeyPatch, tmp_path: object) -> None:
    """In a container the room under its memory limit is what is free, when smaller than the machine's free memory."""
    from pathlib import Path

    from freefloat.core import resources

    monkeypatch.delenv("FREEFLOAT_MEMORY_LIMIT", raising=False)
    files = {"/sys/fs/cgroup/memory.max": "1073741824\n", "/sys/fs/cgroup/memory.current": "268435456\n"}
    real_read = Path.read_text

    def read_text(self: Path, *args: object, **kwargs: object) -> str:
        return files[str(self)] if str(self) in files else real_read(self, *args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(Path, "read_text", read_text)
    assert resources._cgroup_room() == 1073741824 - 268435456
    assert available_memory() == 805306368  # 768 MiB left in the container, less than the machine has free
    files["/sys/fs/cgroup/memory.max"] = "max\n"
    assert resources._cgroup_room() is None

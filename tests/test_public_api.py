"""The public surface: a short top level, namespaces for the rest, every public name documented, the layers kept."""

import dataclasses
import importlib
import inspect
import re
import subprocess
import sys
import types
from pathlib import Path

import pytest

import freefloat as ff

ROOT = Path(__file__).resolve().parents[1]

#: The everyday names of ``import freefloat as ff`` (the issue's list), and nothing else.
EVERYDAY = {
    "Model", "ModelBuilder", "load", "save", "State", "Actuation",
    "FreefloatError", "ModelError", "ShapeError", "UnknownNameError", "SingularConfigurationError",
    "NearSingularWarning", "SimulationError",
    "barycentric_vectors", "BarycentricVectors",
    "forward_kinematics", "end_effector_positions", "body_cm_positions", "point_positions", "body_rotations", "system_cm",
    "point_jacobian", "end_effector_jacobian", "actuation_jacobian", "task_jacobian", "generalized_jacobian",
    "jacobian_determinant", "manipulability",
    "system_inertia_matrix", "inertia_blocks", "angular_momentum", "linear_momentum", "kinetic_energy",
    "nonlinear_forces", "forward_dynamics", "inverse_dynamics", "generalized_forces", "ExternalWrench",
    "simulate", "rollout", "Trajectory", "ActuatorLimits", "JointPD", "Capture",
}  # fmt: skip

#: The namespace modules, attributes of ``freefloat``.
NAMESPACES = ("campaigns", "capture", "control", "conventions", "mechanics", "models", "papers", "planar", "scenarios", "workspace")

#: The top level before it was trimmed: every one of these names must still be reachable.
FORMER_TOP_LEVEL = (
    "Actuation ActuatorLimits BarycentricVectors CaptureFamilies CapturePlan CapturePosture CaptureScenario DesiredPoint "
    "DeterminantMap ExternalWrench FreefloatError FunctionTrajectory GuaranteedWorkspace InertiaBlocks JointPD MinimumJerk "
    "Model ModelBuilder ModelError NearSingularWarning OperationalSpaceController PathDoesNotFitError PathIndependentWorkspace "
    "PathPlacement PayloadEffect ReachableWorkspace Scenario SetPoint ShapeError SimulationError SingularConfigurationError "
    "State StraightLine TaskItem TaskSpace Trajectory TransposedJacobianController UnknownNameError WorkspaceLimits "
    "actuation_from_generalized_forces actuation_jacobian angular_momentum approach_distance barycentric_vectors "
    "body_cm_positions body_rotations capture_families conventions end_effector_jacobian end_effector_positions "
    "end_effector_radius end_effector_rotations forward_dynamics forward_kinematics generalized_forces generalized_jacobian "
    "generalized_jacobian_drift guaranteed_workspace inertia_blocks inverse_dynamics jacobian_determinant "
    "jacobian_determinant_map kinetic_energy linear_momentum load load_capture_scenario load_scenario manipulability models "
    "nonlinear_forces optimal_capture_posture path_independent_workspace payload_effect place_path plan_capture planar "
    "point_bias_acceleration point_jacobian point_positions reachable_workspace rollout run_capture_scenario run_scenario "
    "save simulate singularity_measure spacecraft_fixed_dynamics system_cm system_inertia_matrix system_inertia_matrix_rate "
    "task_jacobian workspace_limits"
).split()


def _namespace(name: str) -> types.ModuleType:
    module = getattr(ff, name)
    assert isinstance(module, types.ModuleType), f"ff.{name} is not a module"
    return module


def _undocumented(obj: object) -> bool:
    """True when a function or class has no docstring of its own (dataclasses and NamedTuples invent one)."""
    doc = obj.__dict__.get("__doc__") if isinstance(obj, type) else getattr(obj, "__doc__", None)
    if not doc or not doc.strip():
        return True
    generated = isinstance(obj, type) and (dataclasses.is_dataclass(obj) or hasattr(obj, "_fields"))
    return generated and doc.startswith(f"{obj.__name__}(")


def test_top_level_is_short() -> None:
    assert len(ff.__all__) <= 50
    assert len(set(ff.__all__)) == len(ff.__all__)


def test_top_level_holds_the_everyday_names() -> None:
    assert set(ff.__all__) == EVERYDAY


def test_namespaces_are_documented_modules() -> None:
    assert set(ff.NAMESPACES) == set(NAMESPACES)
    assert (ff.__doc__ or "").strip()
    for name in NAMESPACES:
        module = _namespace(name)
        assert (module.__doc__ or "").strip(), f"ff.{name} has no module docstring"


@pytest.mark.parametrize("where", ["freefloat", *NAMESPACES])
def test_every_public_name_resolves_and_is_documented(where: str) -> None:
    module = ff if where == "freefloat" else _namespace(where)
    names = list(getattr(module, "__all__", ()))
    assert names, f"{where} has no __all__"
    missing = [n for n in names if not hasattr(module, n)]
    assert not missing, f"{where}.__all__ names that do not resolve: {missing}"
    undocumented = []
    for name in names:
        obj = getattr(module, name)
        if isinstance(obj, types.ModuleType):
            if not (obj.__doc__ or "").strip():
                undocumented.append(name)
        elif (inspect.isfunction(obj) or inspect.isclass(obj)) and _undocumented(obj):
            undocumented.append(name)
    assert not undocumented, f"{where}: no docstring: {undocumented}"


def test_names_that_left_the_top_level_are_in_a_namespace() -> None:
    lost = []
    for name in FORMER_TOP_LEVEL:
        if name in ff.__all__ or name in NAMESPACES:
            continue
        homes = [ns for ns in NAMESPACES if name in getattr(_namespace(ns), "__all__", ())]
        if not homes:
            lost.append(name)
    assert not lost, f"no namespace offers: {lost}"


def test_the_import_contracts_hold() -> None:
    """The layers of docs/architecture.md, as checked by import-linter (contracts in pyproject.toml)."""
    lint_imports = Path(sys.executable).parent / "lint-imports"
    assert lint_imports.exists(), f"{lint_imports} not found: install the test extras (pip install -e '.[test]')"
    run = subprocess.run([str(lint_imports), "--no-cache"], cwd=ROOT, capture_output=True, text=True, check=False)
    assert run.returncode == 0, run.stdout + run.stderr


#: ``ff.X`` / ``freefloat.x.Y`` in prose: a dotted name the docs tell a user to call or import.
_DOTTED = re.compile(r"(?<![\w./-])(?:ff|freefloat)\.([A-Za-z_]\w*(?:\.[A-Za-z_]\w*)*)")


def _unresolved(text: str) -> list[str]:
    """The dotted freefloat names in ``text`` that are neither an attribute nor an importable module."""
    bad = []
    for match in _DOTTED.finditer(text):
        after = text[match.end() : match.end() + 9].lstrip("` \n")
        if match.group(1).split(".")[-1] == "md" or after.startswith("logger"):  # a page, a logger's name
            continue
        obj: object = ff
        where = "freefloat"
        for part in match.group(1).split("."):
            if hasattr(obj, part):
                obj, where = getattr(obj, part), f"{where}.{part}"
                continue
            try:
                obj, where = importlib.import_module(f"{where}.{part}"), f"{where}.{part}"
            except ImportError:
                bad.append(match.group(0))
                break
    return bad


def test_every_name_the_docs_give_exists() -> None:
    """A name in docs/ or the README (``ff.LongRunWarning``, ``freefloat.core.errors.EngineWarning``) that a user would
    import or call resolves; a logger's name and a page's file name are not names."""
    found = {
        f"{path.relative_to(ROOT)}: {name}"
        for path in [*sorted((ROOT / "docs").rglob("*.md")), ROOT / "README.md"]
        for name in _unresolved(path.read_text(encoding="utf-8"))
    }
    assert not found, sorted(found)
    assert _unresolved("`ff.NoSuchWarning`, `freefloat.core.errors.NoSuch`, ff.simulate, `freefloat.progress` logger") == [
        "ff.NoSuchWarning",
        "freefloat.core.errors.NoSuch",
    ]

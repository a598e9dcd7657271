"""Each algorithm is written once: no second implementation of H+, C+ or J* may appear.

H+ (1991 eq. 15), C+ (eq. 19) and J* (1992 eq. 14) all need the bodies' inertias. So the
functions of the package that read inertia data are listed here, each with the one quantity it
is the home of; a new function that reads them (a third H+, a numpy copy of the engine, a
generated kernel) fails this test until it is justified and listed. The same for the functions
that consume the pair inertias, and for the engine's per-configuration kernels. Two homes per
quantity are allowed: the engine (``method="recursive"``) and the barycentric closed form.
The model, its files, the oracles (Pinocchio, MuJoCo) and reports only carry the numbers.
"""

from __future__ import annotations

import ast
from pathlib import Path

import freefloat

PACKAGE = Path(freefloat.__file__).parent
#: Layers that carry mass properties as data without computing H+, C+ or J* from them.
CARRIERS = ("core", "io", "models", "scenarios")

#: Functions allowed to read inertias (attribute ``inertia``/``diagonal_inertia``, or the engine's column ``_I``).
READS_INERTIA = {
    "engine/recursions.py::mass_properties": "engine: inertias about O, composite bodies (H+, C+, J* of the engine)",
    "mechanics/momentum.py::_pair_inertias": "barycentric reference: pair inertias D_ij, 1991 eq. 17",
    "mechanics/dynamics.py::_diagonal_inertias": "barycentric reference: D_ii of C+ (1991 eq. 17)",
    "papers/report.py::model_info": "the report prints the model's mass properties",
    "mechanics/kinematics.py::spacecraft_box_size": "figures: the bus drawn as the uniform box of the spacecraft's inertia (no dynamics)",
    "analysis/singularity.py::SingularityCriterion.measure_bound": (
        "a bound of the singularity measures from the principal moments (no H+, C+ or J*): refuses thresholds nothing reaches"
    ),
    "simulation/coast.py::Coast.__init__": "a target's own torque-free motion before a grasp (Euler's equations of one body)",
    "simulation/coast.py::Coast.at": "the same: the coasting target's angular velocity R I⁻¹ Rᵀ L (no H+, C+ or J*)",
    "analysis/_capture_ranking.py::grasp_setup": "the planned payload handed to the Target of the grasp (data; the impact is mechanics')",
    "mechanics/impact.py::_check_reach": "the target's radius of gyration: is the hand on it (a bound, no dynamics)",
}
#: Functions allowed to use the pair inertias (each one quantity).
USES_PAIRS = {
    "mechanics/momentum.py::_hplus_barycentric": "H+ and its blocks, 1991 eq. 16",
    "mechanics/dynamics.py::_c_plus_barycentric": "C+, closed form (docs/dynamics.md)",
    "mechanics/dynamics.py::_hplus_rate": "dH+/dt (a different quantity: used for momentum checks)",
}
#: The engine's one-configuration kernels and the only places that call them.
ENGINE_KERNELS = {"mass_properties", "centroidal_blocks", "newton_euler", "hplus_one", "jstar_one", "accelerations_one", "unit_momenta"}
ENGINE_CALLERS = {
    "engine/recursions.py",
    "engine/quantities.py",
    "engine/drivers.py",
    "engine/laws.py",  # the control laws: H+ and C+ of the engine (hplus_one), never their own
}
#: Modules allowed to import numba (the compiled engine and its cache).
NUMBA_MODULES = {
    "engine/gate.py",
    "engine/cache.py",
    "engine/folders.py",
    "engine/threads.py",
    "engine/specialise/lanes.py",
    "engine/specialise/build.py",
}


def _functions() -> list[tuple[str, ast.FunctionDef, ast.Module]]:
    out = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE).as_posix()
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef):
                out.append((rel, node, tree))
    return out


def _outermost(rel: str, tree: ast.Module) -> dict[int, str]:
    """line -> the top-level function name enclosing it (nested functions count as their parent)."""
    owner = {}
    for node in tree.body:
        if isinstance(node, ast.FunctionDef):
            for sub in ast.walk(node):
                if hasattr(sub, "lineno"):
                    owner[sub.lineno] = node.name
        elif isinstance(node, ast.ClassDef):
            for item in node.body:
                if isinstance(item, ast.FunctionDef):
                    for sub in ast.walk(item):
                        if hasattr(sub, "lineno"):
                            owner[sub.lineno] = f"{node.name}.{item.name}"
    return owner


def _sites(predicate: object) -> set[str]:
    found = set()
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE).as_posix()
        if rel.split("/")[0] in CARRIERS:
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        owner = _outermost(rel, tree)
        for node in ast.walk(tree):
            if predicate(node):  # type: ignore[operator]
                found.add(f"{rel}::{owner.get(node.lineno, '<module>')}")
    return found


def test_only_the_listed_functions_read_inertias() -> None:
    def reads(node: ast.AST) -> bool:
        return (isinstance(node, ast.Attribute) and node.attr in ("inertia", "diagonal_inertia")) or (
            isinstance(node, ast.Name) and node.id == "_I"
        )

    sites = _sites(reads)
    sites.discard("engine/layout.py::<module>")  # the model layout: the field "inertia" read from the model (data, no computation)
    assert sites == set(READS_INERTIA), (
        f"unlisted readers: {sorted(sites - set(READS_INERTIA))}; gone: {sorted(set(READS_INERTIA) - sites)}"
    )


def test_only_the_listed_functions_use_the_pair_inertias() -> None:
    def uses(node: ast.AST) -> bool:
        return isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in ("_pair_inertias", "_diagonal_inertias")

    sites = _sites(uses)
    assert sites == set(USES_PAIRS), f"unlisted users: {sorted(sites - set(USES_PAIRS))}; gone: {sorted(set(USES_PAIRS) - sites)}"


def test_engine_kernels_are_called_only_inside_the_engine() -> None:
    def calls(node: ast.AST) -> bool:
        return isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in ENGINE_KERNELS

    modules = {site.split("::")[0] for site in _sites(calls)}
    assert modules <= ENGINE_CALLERS, sorted(modules - ENGINE_CALLERS)


def test_numba_is_imported_only_by_the_engine() -> None:
    importers = set()
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE).as_posix()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else []
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                names = [node.module]
            if any(n == "numba" or n.startswith("numba.") for n in names):
                importers.add(rel)
    assert importers == NUMBA_MODULES, sorted(importers ^ NUMBA_MODULES)


def test_the_allowed_homes_exist_and_are_the_two_algorithms() -> None:
    # the listed functions are real (a rename must update this file), and each quantity has exactly two homes
    for site in (*READS_INERTIA, *USES_PAIRS):
        rel, name = site.split("::")
        if name == "<module>":
            continue
        source = (PACKAGE / rel).read_text(encoding="utf-8")
        assert f"def {name.split('.')[-1]}(" in source, site
    homes = {
        "H+": ("engine/quantities.py::hplus_one", "mechanics/momentum.py::_hplus_barycentric"),
        "C+": ("engine/recursions.py::newton_euler", "mechanics/dynamics.py::_c_plus_barycentric"),
        "J*": ("engine/quantities.py::jstar_one", "mechanics/jacobians.py::_gj_barycentric"),
    }
    # the specialised kernels are the engine's J* and state derivative traced, not a third home
    from freefloat.engine import quantities as _configuration
    from freefloat.engine.specialise import trace as _trace

    assert _trace.ENTRY_POINTS == {
        "jstar": "jstar_one",
        "rollout": "state_derivative_one",
        "hplus": "hplus_one",
        "forward": "accelerations_one",
        "inverse": "inverse_one",
    }
    for name in _trace.ENTRY_POINTS.values():  # the traced functions run the engine kernels' own code
        assert getattr(_trace.traced().configuration, name).__code__ is getattr(_configuration, name).py_func.__code__
    for quantity, pair in homes.items():
        for site in pair:
            rel, name = site.split("::")
            assert f"def {name}(" in (PACKAGE / rel).read_text(encoding="utf-8"), (quantity, site)

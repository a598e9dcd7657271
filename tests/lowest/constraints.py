"""Write a pip constraints file that pins freefloat's dependencies to the lowest versions pyproject.toml declares.

``python tests/lowest/constraints.py OUT`` reads ``[project] dependencies``, the ``mjcf`` extra and the test tools
that ``make test-lowest`` runs (:data:`TEST_TOOLS`, from the ``test`` extra) and writes one ``name==LOW`` line per
dependency, LOW its ``>=`` bound (``pip install -c OUT -e .[mjcf]`` then installs exactly those versions; what they
need themselves is left to pip). A dependency without a ``>=`` bound is an error: it would not be tested at its
lowest version. ``python tests/lowest/constraints.py --installed`` prints the versions installed next to those lower
bounds and fails where they differ.
"""

from __future__ import annotations

import re
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

#: The extras whose dependencies are pinned with the runtime ones (the optional MJCF reader).
EXTRAS = ("mjcf",)
#: The test tools of the ``test`` extra that ``make test-lowest`` installs, pinned at their declared lower bound too.
TEST_TOOLS = ("pytest", "pytest-xdist", "hypothesis")

_REQUIREMENT = re.compile(r"^\s*(?P<name>[A-Za-z0-9][A-Za-z0-9._-]*)\s*(?:\[[^\]]*\])?\s*(?P<specifiers>[^;]*?)\s*(?:;.*)?$")


def canonical(name: str) -> str:
    """The name as pip compares names (PEP 503): lower case, runs of ``-_.`` as one ``-``."""
    return re.sub(r"[-_.]+", "-", name).lower()


def _name(requirement: str) -> str:
    match = _REQUIREMENT.match(requirement)
    return canonical(match["name"]) if match else ""


def lower_bound(requirement: str, where: str) -> tuple[str, str]:
    """``(name, LOW)`` of a requirement string ``name[extras]>=LOW,...``; a clear error naming it without a ``>=``."""
    match = _REQUIREMENT.match(requirement)
    if match is None:
        raise SystemExit(f"{where}: cannot read the requirement {requirement!r}")
    lows = [s.strip()[2:].strip() for s in match["specifiers"].split(",") if s.strip().startswith(">=")]
    if len(lows) != 1:
        raise SystemExit(f"{where}: {requirement!r} has no single '>=' lower bound: declare the lowest version that works (name>=LOW)")
    return canonical(match["name"]), lows[0]


def pins(pyproject: Path) -> dict[str, str]:
    """Every pinned dependency's name and lowest version, in the order of pyproject.toml (the runtime ones first)."""
    project = tomllib.loads(pyproject.read_text(encoding="utf-8"))["project"]
    extras = project.get("optional-dependencies", {})
    found: dict[str, str] = {}
    chosen = [("project.dependencies", r) for r in project["dependencies"]]
    for extra in EXTRAS:
        chosen += [(f"project.optional-dependencies.{extra}", r) for r in extras[extra]]
    tools = {canonical(t) for t in TEST_TOOLS}
    chosen += [("project.optional-dependencies.test", r) for r in extras["test"] if _name(r) in tools]
    for where, requirement in chosen:
        name, low = lower_bound(requirement, f"{pyproject}: {where}")
        if found.get(name, low) != low:
            raise SystemExit(f"{pyproject}: {name} has two lower bounds ({found[name]} and {low}): declare one")
        found[name] = low
    missing = tools - found.keys()
    if missing:
        raise SystemExit(f"{pyproject}: project.optional-dependencies.test does not name {sorted(missing)}")
    return found


def installed() -> None:
    """Print each pinned dependency's lower bound and the version installed in this Python's environment; exit 1 when
    one is missing or another version (the environment is not the lowest one)."""
    from importlib.metadata import PackageNotFoundError, version

    wrong = []
    for name, low in pins(ROOT / "pyproject.toml").items():
        try:
            found = version(name)
        except PackageNotFoundError:
            found = "not installed"
        same = found != "not installed" and _release(found) == _release(low)
        wrong += [] if same else [name]
        print(f"{name:<14} >={low:<10} installed {found}{'' if same else '  <- not the lower bound'}")
    if wrong:
        raise SystemExit(f"not at their declared lower bounds: {wrong}")


def _release(text: str) -> tuple[int, ...]:
    """The release numbers of a version, trailing zeros dropped (``3`` and ``3.0.0`` are one version)."""
    numbers = [int(part) for part in re.match(r"\d+(?:\.\d+)*", text)[0].split(".")]  # type: ignore[index]
    while len(numbers) > 1 and numbers[-1] == 0:
        numbers.pop()
    return tuple(numbers)


def main(argv: list[str]) -> None:
    if argv == ["--installed"]:
        installed()
        return
    if len(argv) != 1 or argv[0].startswith("-"):
        raise SystemExit("usage: python tests/lowest/constraints.py OUT (the constraints file to write) | --installed (check them)")
    lines = [f"{name}=={low}" for name, low in pins(ROOT / "pyproject.toml").items()]
    header = "# freefloat's declared lower bounds (tests/lowest/constraints.py writes this file from pyproject.toml)\n"
    Path(argv[0]).write_text(header + "\n".join(lines) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main(sys.argv[1:])

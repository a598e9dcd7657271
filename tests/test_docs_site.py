"""The documentation site builds as ``make docs`` builds it: strict, with the API reference and the papers' results.

``make docs`` runs ``make demo`` and then MkDocs with ``--strict`` (any warning fails: a broken link, a
public name without a docstring, a docstring griffe cannot read). This test runs that recipe, read from
the Makefile, into a scratch folder, and reads the pages it made.
"""

from __future__ import annotations

import html
import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

import freefloat as ff
from images import check_paper_figure

ROOT = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent


def recipe(target: str, out: Path) -> list[str]:
    """The command lines of ``make TARGET``, with this environment's executables and ``OUT`` = ``out``."""
    text = (ROOT / "Makefile").read_text(encoding="utf-8")
    found = re.search(rf"^{target}:(.*)\n((?:\t.*\n)+)", text, flags=re.M)
    assert found, f"Makefile has no {target!r} target"
    lines = [line.strip() for line in found.group(2).splitlines()]
    return [line.replace("$(VENV)/bin/", f"{BIN}/").replace("$(PY)", sys.executable).replace("$(OUT)", str(out)) for line in lines]


def hooks() -> Any:
    """The hooks module of mkdocs.yml, loaded from its file as MkDocs loads it."""
    spec = importlib.util.spec_from_file_location("_site_hooks", ROOT / "docs" / "_site_hooks.py")
    assert spec and spec.loader
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``make docs`` (its prerequisite ``demo`` first), run as the Makefile says, into a scratch OUT."""
    out = tmp_path_factory.mktemp("docs_out")
    assert re.search(r"^docs:.*\bdemo\b", (ROOT / "Makefile").read_text(encoding="utf-8"), flags=re.M), "make docs must run make demo first"
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    for line in recipe("demo", out) + recipe("docs", out):
        result = subprocess.run(line, shell=True, cwd=ROOT, env=env, capture_output=True, text=True, timeout=900)
        assert result.returncode == 0, f"`{line}` failed:\n{result.stdout[-3000:]}\n{result.stderr[-3000:]}"
        assert "WARNING" not in result.stderr, result.stderr
    return out / "site"


def test_the_build_is_strict() -> None:
    """``make docs`` builds with ``--strict``, and mkdocs.yml turns every link check into a warning."""
    assert any("mkdocs build --strict" in line for line in recipe("docs", Path("out")))
    config = (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    assert "strict: true" in config and config.count(": warn") == 7


def test_guides_reference_and_results(site: Path) -> None:
    for guide in "theory dynamics simulation control workspaces impact model-files conventions paper-notes architecture".split():
        page = (site / guide / "index.html").read_text(encoding="utf-8")
        title = (ROOT / "docs" / f"{guide}.md").read_text(encoding="utf-8").splitlines()[0].removeprefix("# ")
        assert re.search(rf"<h1[^>]*>{re.escape(html.escape(title, quote=False))}", page), (guide, title)  # the guide's own page
    workspaces = (site / "workspaces" / "index.html").read_text(encoding="utf-8")
    assert "<td>T6.PIW_min</td>" in workspaces and "<td>0.36886</td>" in workspaces  # its paper-vs-freefloat table
    # the API reference: every exported name of ff and its namespaces, with the paper equation of its docstring
    reference = (site / "reference" / "freefloat" / "index.html").read_text(encoding="utf-8")
    for name in ff.__all__:
        assert f'id="freefloat.{name}"' in reference, name
    jstar = reference[reference.index('id="freefloat.generalized_jacobian"') :][:4000]
    assert "1992 eq. 14" in jstar
    hplus = reference[reference.index('id="freefloat.system_inertia_matrix"') :][:4000]
    assert "1991" in hplus and "15" in hplus
    for namespace in ff.NAMESPACES:
        module = getattr(ff, namespace)
        page = (site / "reference" / namespace / "index.html").read_text(encoding="utf-8")
        for name in module.__all__:
            if not isinstance(getattr(module, name), type(ff)):  # a submodule has its own page
                assert f'id="{module.__name__}.{name}"' in page, f"{namespace}.{name}"
    for page in (site / "reference").glob("*/index.html"):  # Sphinx roles shown as code, on every page
        assert not re.search(r":(?:py:)?[a-z]+:(?:<code>|`)", page.read_text(encoding="utf-8")), page
    # the command line: each command's help, as the command prints it
    cli = (site / "cli" / "index.html").read_text(encoding="utf-8")
    for command in ("inspect", "specialise", "demo", "workspace", "capture", "simulate", "reproduce", "campaign"):
        assert f"Usage: freefloat {command} [OPTIONS]" in cli, command
    # the papers reproduced: make demo's tables and figures
    for paper in ("1991", "1992"):
        page = (site / "results" / paper / "report" / "index.html").read_text(encoding="utf-8")
        assert f"{paper[2:]}.S5" in page
        figures = re.findall(r'<img[^>]+src="([^"]+\.png)"', page)
        assert len(figures) >= 4, figures
        for figure in figures:
            check_paper_figure((site / "results" / paper / "report" / figure).resolve())
    assert "92.T2.arm1.alpha" in (site / "results" / "1992" / "report" / "index.html").read_text(encoding="utf-8")
    overview = (site / "results" / "index.html").read_text(encoding="utf-8")
    assert "agree at the printed precision" in overview and f"freefloat {ff.__version__}" in overview


def test_a_public_name_without_a_docstring_is_found(tmp_path: Path) -> None:
    """The check behind the strict build, on a package with one undocumented function and one documented."""
    package = tmp_path / "pkg"
    package.mkdir()
    (package / "__init__.py").write_text(
        '"""A package."""\n__all__ = ["Thing", "documented", "undocumented"]\n\n'
        'def documented():\n    """Documented."""\n\n'
        "def undocumented():\n    pass\n\n"
        'class Thing:\n    """A thing."""\n\n    def method(self):\n        pass\n\n    def _private(self):\n        pass\n',
        encoding="utf-8",
    )
    missing = hooks().missing_docstrings({"pkg": "pkg"}, [str(tmp_path)])
    assert missing == ["pkg.Thing.method (pkg.Thing.method)", "pkg.undocumented (pkg.undocumented)"]
    assert hooks().missing_docstrings(hooks().public_modules(), [str(ROOT / "src")]) == []


def test_results_need_the_demo(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Without make demo's outputs the build stops with a line that says to run it."""
    from mkdocs.exceptions import PluginError

    monkeypatch.setenv("FREEFLOAT_DEMO_OUT", str(tmp_path / "nothing"))
    with pytest.raises(PluginError, match=r"run `make demo` first"):
        hooks().demo_folder()


def test_docstrings_written_for_a_terminal_read_right_in_markdown() -> None:
    rewrite = hooks().rewrite_docstring
    assert rewrite("See :func:`~freefloat.mechanics.point_jacobian` and :py:class:`freefloat.Model`.") == (
        "See ``point_jacobian`` and ``freefloat.Model``."
    )
    assert rewrite(":meth:`the plot <freefloat.Trajectory.plot>`, :data:`!BUILTIN_MODELS`") == "``the plot``, ``BUILTIN_MODELS``"
    table = "mass   (B,)  kg, per body\ncom    (B, 3)  CM in the body frame, see :func:`~a.b`"
    assert rewrite("Fields.\n\n" + table) == "Fields.\n\n```text\n" + table.replace(":func:`~a.b`", "b") + "\n```"
    doctest = ">>> import freefloat as ff\n>>> ff.models.papadopoulos1992()"
    assert rewrite(doctest) == "```pycon\n" + doctest + "\n```"
    prose = "The system CM, in the spacecraft frame. Two sentences.  Double-spaced.\nA second line."
    assert rewrite(prose) == prose


def test_a_strict_build_fails_on_a_broken_link_and_on_a_name_without_a_docstring(
    site: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """mkdocs.yml's strict build of a page with a broken link aborts; a missing docstring is a warning of the
    ``mkdocs`` logger, which the strict build counts the same way."""
    from mkdocs.commands.build import build
    from mkdocs.config import load_config
    from mkdocs.exceptions import Abort

    monkeypatch.chdir(ROOT)
    monkeypatch.setenv("FREEFLOAT_DEMO_OUT", str(site.parent))
    docs = tmp_path / "docs"
    docs.mkdir()
    (docs / "index.md").write_text("# Home\n\n[a page that is not there](missing.md)\n", encoding="utf-8")
    config = load_config(str(ROOT / "mkdocs.yml"), docs_dir=str(docs), site_dir=str(tmp_path / "site"), nav=None)
    config.plugins.on_startup(command="build", dirty=False)
    try:
        with pytest.raises(Abort, match="strict mode"):
            build(config)
    finally:
        config.plugins.on_shutdown()
    assert any("missing.md" in r.getMessage() and r.levelname == "WARNING" for r in caplog.records)

    module = hooks()
    monkeypatch.setattr(module, "missing_docstrings", lambda modules, paths: ["freefloat.thing (freefloat.core.thing)"])
    caplog.clear()
    module.on_pre_build(config)
    [record] = caplog.records
    assert record.levelname == "WARNING" and record.name.startswith("mkdocs.") and "freefloat.thing" in record.getMessage()

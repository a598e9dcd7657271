"""Hooks of the documentation site (``mkdocs.yml``; ``make docs`` builds it with ``--strict``).

- **Every public name has a docstring.** Before the build, each name exported (``__all__``) by
  ``freefloat`` and by its namespaces (``freefloat.NAMESPACES``), and each public method and property of
  an exported class, is looked up with griffe (the library mkdocstrings reads the docstrings with); one
  without a docstring is a warning, which ``--strict`` makes fatal. Dataclass fields are described in
  their class's docstring.
- **The papers reproduced.** The pages under ``results/`` are the reports and figures that
  ``make demo`` wrote (``freefloat demo --out OUT``), read from the folder named by the environment
  variable ``FREEFLOAT_DEMO_OUT`` (``out`` by default); a missing report stops the build with a line
  that says to run ``make demo`` first. Nothing here computes a result.
- **The command line**: the ``cli.md`` page is each command's ``--help``, as ``freefloat`` prints it.
- **Docstrings written for a terminal** (Sphinx roles, field tables in aligned columns, doctests) are
  rewritten for Markdown by :func:`rewrite_docstring`, through a griffe extension
  (:class:`SphinxRolesAsCode`, listed in the mkdocstrings options of ``mkdocs.yml``).
"""

from __future__ import annotations

import json
import logging
import os
import re
from pathlib import Path
from typing import Any

import griffe
from mkdocs.exceptions import PluginError
from mkdocs.structure.files import File, Files

log = logging.getLogger("mkdocs.hooks.freefloat")

ROOT = Path(__file__).resolve().parents[1]
DEMO_ENV = "FREEFLOAT_DEMO_OUT"
PAPERS = {"1991": "Papadopoulos & Dubowsky 1991, §V", "1992": "Papadopoulos 1992, Tables II-VI and §V"}


# --------------------------------------------------------------------- docstrings
def public_modules(package: str = "freefloat") -> dict[str, str]:
    """The modules whose ``__all__`` is the public API: the package and each of its namespaces."""
    import importlib

    root = importlib.import_module(package)
    return {package: package, **{f"{package}.{ns}": getattr(root, ns).__name__ for ns in root.NAMESPACES}}


def missing_docstrings(modules: dict[str, str], search_paths: list[str]) -> list[str]:
    """Public names without a docstring, as ``public.name (defined.at.path)``, read by griffe."""
    package = next(iter(modules.values())).split(".")[0]
    loaded = griffe.load(package, search_paths=search_paths, resolve_aliases=True, resolve_external=False)
    missing: list[str] = []
    seen: set[str] = set()
    for public, path in modules.items():
        module = loaded[path.removeprefix(package + ".")] if path != package else loaded
        if not module.docstring:
            missing.append(f"{public} (module {path})")
        for name in sorted(str(n) for n in module.exports or ()):
            if name not in module.members:
                missing.append(f"{public}.{name} (in __all__ but not defined)")
                continue
            obj = module[name]
            target = obj.final_target if obj.is_alias else obj
            if target.path in seen:
                continue
            seen.add(target.path)
            if not target.docstring:
                missing.append(f"{public}.{name} ({target.path})")
            if target.is_class:
                for member_name, member in target.members.items():
                    if member_name.startswith("_") or member.is_alias:
                        continue
                    if (member.is_function or "property" in member.labels) and not member.docstring:
                        missing.append(f"{public}.{name}.{member_name} ({member.path})")
    return missing


def on_pre_build(config: Any) -> None:
    """Warn (fatal under ``--strict``) for each public name without a docstring."""
    src = str(ROOT / "src")
    for entry in missing_docstrings(public_modules(), [src]):
        log.warning("public name without a docstring: %s; write one (the API reference is made from it)", entry)


class SphinxRolesAsCode(griffe.Extension):
    """Docstrings written for a terminal, shown as written on the site (:func:`rewrite_docstring`)."""

    def on_instance(self, *, obj: griffe.Object, **kwargs: Any) -> None:
        """Rewrite one object's docstring as it is loaded."""
        if obj.docstring is not None:
            obj.docstring.value = rewrite_docstring(obj.docstring.value)


_ROLE = re.compile(r":(?:py:)?(?:func|class|mod|meth|data|attr|exc|obj|const):`(?P<mark>[~!]?)(?P<body>[^`]+)`")
_COLUMNS = re.compile(r"[^\s.,;:] {2,}\S")


def _role_text(match: re.Match[str]) -> str:
    body = match["body"]
    if body.endswith(">") and "<" in body:  # an explicit title: :func:`text <target>`
        return body[: body.index("<")].strip()
    return body.rsplit(".", 1)[-1] if match["mark"] == "~" else body


def rewrite_docstring(text: str) -> str:
    """A docstring written for ``help()``, rewritten for Markdown.

    - Sphinx roles (``:func:`~freefloat.x```, ``:py:class:`a.B```, ``:meth:`text <a.b>```) become inline
      code (``x``, ``a.B``, ``text``).
    - A paragraph laid out in aligned columns (a field table: name, shape, meaning, two or more spaces
      apart) keeps its layout as a preformatted block, where Markdown would join its lines into one; its
      roles and double backquotes become plain text there.
    - A doctest paragraph (``>>>`` lines) is shown as a Python console session.
    """
    paragraphs = []
    for paragraph in text.split("\n\n"):
        lines = paragraph.splitlines()
        if "```" not in paragraph and lines and lines[0].lstrip().startswith(">>> "):
            paragraph = "```pycon\n" + paragraph + "\n```"
        elif "```" not in paragraph and sum(bool(_COLUMNS.search(line.strip())) for line in lines) >= 2:
            paragraph = "```text\n" + _ROLE.sub(_role_text, paragraph).replace("``", "") + "\n```"
        else:
            paragraph = _ROLE.sub(lambda m: f"``{_role_text(m)}``", paragraph)
        paragraphs.append(paragraph)
    return "\n\n".join(paragraphs)


# --------------------------------------------------------------------- the papers reproduced
def demo_folder() -> Path:
    """Where ``make demo`` wrote its outputs (``FREEFLOAT_DEMO_OUT``, else ``out``), checked."""
    folder = Path(os.environ.get(DEMO_ENV, "out"))
    folder = folder if folder.is_absolute() else ROOT / folder
    for paper in PAPERS:
        if not (folder / paper / "report.md").is_file() or not (folder / paper / "report.json").is_file():
            raise PluginError(
                f"the 'papers reproduced' pages need the outputs of `make demo`, and {folder / paper / 'report.md'} "
                f"is missing: run `make demo` first (or set {DEMO_ENV} to the folder `freefloat demo --out` wrote)"
            )
    return folder


def results_index(folder: Path) -> str:
    """The overview page: each paper's row counts (as its ``report.md`` counts them), from the demo's ``report.json``."""
    from freefloat import __version__
    from freefloat.papers.paper_report import report_summary

    lines = [
        "# Papers reproduced",
        "",
        f"These pages are what `make demo` (`freefloat demo --out OUT`, freefloat {__version__}) wrote: for each paper",
        "its figures and the paper-vs-freefloat table. `paper` is the number the paper prints, `ours` freefloat's own",
        "answer to the quantity as the paper defines it (computed, never typed in), `agrees` whether `ours` rounds",
        "to the printed value at the printed precision; where they differ, the row's note says why.",
        "[Paper notes](../paper-notes.md) discusses the differences.",
        "",
        "| paper | rows | compared with the paper | agree at the printed precision |",
        "|---|---:|---:|---:|",
    ]
    for paper, title in PAPERS.items():
        n_rows, compared, agree = report_summary(json.loads((folder / paper / "report.json").read_text(encoding="utf-8"))["rows"])
        lines.append(f"| [{title}]({paper}/report.md) | {n_rows} | {compared} | {agree} |")
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------- the command line
def cli_page() -> str:
    """The ``cli.md`` page: ``freefloat --help`` and each command's ``--help``, as the command prints them."""
    import typer
    from typer.testing import CliRunner

    from freefloat.cli import app

    env = {"NO_COLOR": "1", "TERM": "dumb", "COLUMNS": "88", "TERMINAL_WIDTH": "88"}
    lines = [
        "# Command line",
        "",
        "`freefloat COMMAND ...` or `python -m freefloat COMMAND ...`. Bad input prints one `error: ...` line and exits",
        "with code 1; `--out` folders are created, and a run never replaces a file there that freefloat did not write.",
        "This page is the help each command prints (`freefloat COMMAND --help`), generated when the site is built.",
    ]
    for name in ["", *typer.main.get_command(app).commands]:  # type: ignore[attr-defined]
        result = CliRunner().invoke(app, [name, "--help"] if name else ["--help"], env=env)
        if result.exit_code != 0:
            raise PluginError(f"`freefloat {name} --help` failed: {result.output}")
        title = f"`freefloat {name}`" if name else "`freefloat`"
        lines += ["", f"## {title}", "", "```text", result.output.strip("\n").rstrip(), "```"]
    return "\n".join(lines) + "\n"


def on_files(files: Files, config: Any) -> Files:
    """Add the command-line page and the demo's reports and figures (the pages under ``results/``)."""
    files.append(File.generated(config, "cli.md", content=cli_page()))
    folder = demo_folder()
    files.append(File.generated(config, "results/index.md", content=results_index(folder)))
    for paper in PAPERS:
        for path in sorted((folder / paper).iterdir()):
            if path.suffix in (".md", ".png"):
                files.append(File.generated(config, f"results/{paper}/{path.name}", abs_src_path=str(path)))
    return files

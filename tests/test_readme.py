"""The README's quickstart runs as written."""

import re
from pathlib import Path

README = Path(__file__).resolve().parents[1] / "README.md"


def python_blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), flags=re.S)


def test_readme_has_a_quickstart():
    assert python_blocks(), "README.md lost its ```python quickstart block"


def test_readme_quickstart_runs(capsys):
    scope = {"__name__": "readme"}  # one scope: the blocks are read top to bottom
    for block in python_blocks():
        exec(compile(block, str(README), "exec"), scope)
    out = capsys.readouterr().out
    assert "alpha=0.230 beta=0.483 gamma=0.523" in out


DOCS_WITH_CODE = ("simulation.md",)


def test_docs_python_blocks_run(tmp_path, monkeypatch):
    """The ```python blocks of the docs listed in DOCS_WITH_CODE run as written (in a scratch directory)."""
    monkeypatch.chdir(tmp_path)
    for name in DOCS_WITH_CODE:
        path = README.parent / "docs" / name
        blocks = re.findall(r"```python\n(.*?)```", path.read_text(encoding="utf-8"), flags=re.S)
        assert blocks, f"{name} has no ```python block"
        scope = {"__name__": "docs"}
        for block in blocks:
            exec(compile(block, str(path), "exec"), scope)

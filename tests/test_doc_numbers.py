"""The numbers the docs quote from a command's output are what the command prints (issue 40 item 8).

Every ```console block of docs/*.md that starts with ``$ freefloat ...`` is an example: its command is run (from
the repository root, in this process) and each line the block shows is looked up in what it prints: the line whose
words are the same, with every number equal to the precision the doc prints it with (0.000000 and 0 agree; 13.95
and 5.75 do not). A line ending with ``...`` is a prefix; a line that is only ``...`` stands for lines left out.
Nothing is typed in here: the commands, the lines and the numbers are read from the pages.
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest
from typer.testing import CliRunner

from freefloat.cli import app

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
#: A number as the commands print them: 12, -0.5, 1.03e-4, 5e+298 (inside names too: both sides alike).
NUMBER = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")
#: The pages whose examples must be checked (more pages join when they quote a command's output).
REQUIRED = ("impact.md", "wheels.md")


def examples() -> list[tuple[str, str, list[str]]]:
    """(page, command, the output lines it quotes) of every ``$ freefloat`` console block of the docs."""
    found = []
    for page in sorted(DOCS.glob("*.md")):
        for block in re.findall(r"^```console\n(.*?)^```", page.read_text(), flags=re.S | re.M):
            lines = block.rstrip("\n").split("\n")
            if lines[0].startswith("$ freefloat "):
                found.append((page.name, lines[0][2:], lines[1:]))
    return found


EXAMPLES = examples()


def _skeleton(text: str) -> str:
    return NUMBER.sub("#", " ".join(text.split()))


def _agrees(doc: str, printed: str) -> bool:
    """``printed`` equals ``doc`` to the precision ``doc`` is written with (half a unit of its last digit)."""
    mantissa, _, exponent = doc.lower().partition("e")
    decimals = len(mantissa.partition(".")[2])
    unit = 10.0 ** ((int(exponent) if exponent else 0) - decimals)
    return abs(float(doc) - float(printed)) <= 0.5 * unit * (1.0 + 1e-9)


def _mismatch(quoted: str, printed: list[str]) -> str | None:
    """None when a printed line matches the quoted one (words equal, numbers to the quoted precision); else why not."""
    prefix = quoted.rstrip().endswith("...")
    want = quoted.rstrip().removesuffix("...").rstrip(" ,;")
    skeleton, numbers = _skeleton(want), NUMBER.findall(want)
    closest = None
    for line in printed:
        have = _skeleton(line)
        if not (have.startswith(skeleton) if prefix else have == skeleton):
            continue
        values = NUMBER.findall(line)[: len(numbers)]
        wrong = [(d, p) for d, p in zip(numbers, values, strict=True) if not _agrees(d, p)]
        if not wrong:
            return None
        closest = f"the command prints {line.strip()!r}: " + ", ".join(f"{d} (doc) vs {p} (printed)" for d, p in wrong)
    return closest or f"no printed line reads like {quoted.strip()!r}"


def test_the_pages_quote_examples() -> None:
    pages = {page for page, _, _ in EXAMPLES}
    assert set(REQUIRED) <= pages, pages


@pytest.mark.parametrize(("page", "command", "quoted"), EXAMPLES, ids=[f"{p}:{c.split()[2]}" for p, c, _ in EXAMPLES])
def test_the_quoted_output_is_what_the_command_prints(page: str, command: str, quoted: list[str], monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(ROOT)  # the examples' paths are relative to the repository
    result = CliRunner().invoke(app, shlex.split(command)[1:])
    assert result.exit_code == 0, result.output
    printed = result.stdout.splitlines()
    lines = [q for q in quoted if q.strip() and q.strip() != "..."]
    assert lines, f"{page}: the example `{command}` quotes no output"
    problems = [f"{page}: {why}" for q in lines if (why := _mismatch(q, printed)) is not None]
    assert not problems, "\n".join(problems)
    assert sum(len(NUMBER.findall(q)) for q in lines) > 0

"""The CLI on a real terminal (a pseudo-terminal as standard error): progress is drawn there and leaves nothing behind.

Issue "What a user still meets", item 7: the steps of ``workspace`` show a spinner, the step count ("[3/6]") and the
count of sampled configurations; the bar is transient (erased when the step ends), and standard error gets no
stray blank lines.
"""

from __future__ import annotations

import json
import os
import pty
import re
import subprocess
import sys
from pathlib import Path

from printed_1992 import paper_or_documented

ANSI = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")


def _run_on_a_terminal(argv: list[str], cwd: Path) -> tuple[int, str, str]:
    """Run the CLI with standard error on a pseudo-terminal (80 columns); (exit code, stdout, stderr as drawn)."""
    leader, follower = pty.openpty()
    env = {**os.environ, "COLUMNS": "120", "TERM": "xterm-256color"}
    proc = subprocess.Popen([sys.executable, "-m", "freefloat", *argv], cwd=cwd, stdout=subprocess.PIPE, stderr=follower, env=env)
    os.close(follower)
    chunks: list[bytes] = []
    while True:
        try:
            data = os.read(leader, 65536)
        except OSError:  # the child closed the terminal
            break
        if not data:
            break
        chunks.append(data)
    out, _ = proc.communicate(timeout=120)
    os.close(leader)
    return proc.returncode, out.decode(), b"".join(chunks).decode(errors="replace")


def test_workspace_progress_on_a_terminal(tmp_path: Path) -> None:
    code, out, err = _run_on_a_terminal(["workspace", "papadopoulos1992", "--samples", "300000", "--out", "ws"], tmp_path)
    assert code == 0, err
    drawn = [ANSI.sub("", frame) for frame in re.split(r"\r|\n", err)]
    steps = {m.group(0) for frame in drawn for m in re.finditer(r"\[\d/6\] (reachable|guaranteed) workspace of arm\d_ee", frame)}
    assert len(steps) == 4, drawn  # every step was shown
    counts = [m.group(1) for frame in drawn for m in re.finditer(r"([\d,]+/[\d,]+|[\d,]+ / [\d,]+) configurations", frame)]
    assert counts, drawn  # the PIW sampling shows its count of configurations
    # what remains on the terminal once the transient bars are erased: only the lines the command printed
    final = [line for line in ANSI.sub("", err.replace("\r\n", "\n")).split("\n")]
    kept = [line.rsplit("\r", 1)[-1].strip() for line in final]
    assert "" not in kept[:-1], kept  # no blank line (the last element is after the final newline)
    assert "workspace.json" in out + err
    data = json.loads((tmp_path / "ws" / "workspace.json").read_text())  # what the steps computed, written
    assert [e["name"] for e in data["end_effectors"]] == ["arm1_ee", "arm2_ee"]
    for m, entry in enumerate(data["end_effectors"], start=1):
        paper_or_documented(f"92.T3.arm{m}.R_max", entry["reachable"]["R_max"])  # 1992 Table III: 2.50
        paper_or_documented(f"92.T3.arm{m}.GW_min", entry["guaranteed"]["R_min"])  # 0.68519, printed 0.686 (documented)

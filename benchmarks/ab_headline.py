"""The headline figures of ``make bench``: this checkout against an earlier revision, in alternated processes.

    python benchmarks/ab_headline.py --out out/bench                      # against BASE, 2 rounds
    python benchmarks/ab_headline.py --out out/bench --base REV --rounds 3 --startup

Each round runs ``benchmarks/run.py --only core --only dynamics --only control`` once for each revision, the base
first and this checkout next, in fresh processes: the earlier revision from a ``git worktree`` in a temporary folder
(its own benchmarks, its own engine, its own kernel cache: ``run.py`` warms every kernel before timing anything).
``--startup`` adds one run of the start-up benchmark per revision (its cold figure compiles every kernel: minutes).
The report has, for every rate or time that both revisions measured under the same name (and J* into the caller's
``out=``, which the base lacks, against the base's J*: ``base_figure`` names it), each revision's best over the
rounds and the ratio this / base as a speed (above 1: this checkout is faster), with the load average of every run.
The machine is noisy: a ratio within the spread of one revision's own rounds is noise, and the report gives that
spread. Not part of ``make bench`` (it runs ``make bench``'s core twice per round).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

#: The commit the engine issue (43) was filed against.
BASE = "1dcf09e"
ROOT = Path(__file__).resolve().parents[1]
HEADLINE = ("core", "dynamics", "control")
#: A figure of this checkout compared with another of the base, where the base has no figure of that name: J* into
#: the caller's ``out=`` against the base's J* without it (the base recycled its own outputs, which this checkout
#: leaves to the caller).
COUNTERPARTS = (("/jstar_out/", "/jstar/"),)


def flatten(report: Any, prefix: str = "") -> dict[str, float]:
    """The numbers of a benchmark report by their key path (``a/b/c``); lists are indexed."""
    out: dict[str, float] = {}
    items = report.items() if isinstance(report, dict) else enumerate(report) if isinstance(report, list) else ()
    for key, value in items:
        path = f"{prefix}/{key}" if prefix else str(key)
        if isinstance(value, bool):
            continue
        if isinstance(value, (int, float)):
            out[path] = float(value)
        else:
            out.update(flatten(value, path))
    return out


def direction(path: str) -> int:
    """+1 for a rate (higher is better), -1 for a time (lower is better), 0 for anything else (not compared)."""
    leaf = path.rsplit("/", 1)[-1]
    if "machine" in path or "verification" in path or "error" in leaf or "err" in leaf:
        return 0
    if leaf.endswith("per_s") or leaf.endswith("_per_second"):
        return 1
    if leaf in ("best_s", "seconds", "wall_s") or leaf.endswith("_seconds"):
        return -1
    return 0


def run_once(root: Path, out: Path, only: tuple[str, ...]) -> dict[str, Any]:
    """``benchmarks/run.py`` of the checkout at ``root`` into ``out``: its reports by benchmark name."""
    env = dict(os.environ, PYTHONPATH=str(root / "src"))
    args = [sys.executable, str(root / "benchmarks" / "run.py"), "--out", str(out)]
    for name in only:
        args += ["--only", name]
    subprocess.run(args, cwd=root, env=env, check=True)
    return {name: json.loads((out / f"{name}.json").read_text()) for name in only}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, default=Path("out/bench"))
    parser.add_argument("--base", default=BASE, help=f"the earlier revision (default {BASE})")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--startup", action="store_true", help="also the start-up benchmark, once per revision")
    parser.add_argument("--this", type=Path, default=ROOT, help="the checkout to measure against the base (default: this one)")
    args = parser.parse_args(argv)
    if args.rounds < 1:
        parser.error("--rounds: expected 1 or more")
    this_root = args.this.resolve()
    out = args.out.resolve() / "ab-headline"
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="ff-ab-") as tmp:
        base_root = Path(tmp) / "base"
        subprocess.run(["git", "worktree", "add", "--detach", str(base_root), args.base], cwd=ROOT, check=True)
        try:
            runs: dict[str, list[dict[str, Any]]] = {"base": [], "this": []}
            for r in range(args.rounds):
                for label, root in (("base", base_root), ("this", this_root)):
                    print(f"== round {r + 1} of {args.rounds}: {label} ==", flush=True)
                    runs[label].append(run_once(root, out / label / str(r), HEADLINE))
            if args.startup:
                for label, root in (("base", base_root), ("this", this_root)):
                    print(f"== start-up: {label} ==", flush=True)
                    runs[label].append(run_once(root, out / label / "startup", ("startup",)))
        finally:
            subprocess.run(["git", "worktree", "remove", "--force", str(base_root)], cwd=ROOT, check=False)
    report = compare(runs)
    report["base"] = args.base
    report["this"] = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=this_root, capture_output=True, text=True).stdout.strip()
    (args.out / "ab_headline.json").write_text(json.dumps(report, indent=1))
    print(table(report))
    return 0


def compare(runs: dict[str, list[dict[str, Any]]]) -> dict[str, Any]:
    """Best and spread of every figure both revisions measured, and the speed ratio this / base."""
    flat = {label: [flatten(r) for r in rs] for label, rs in runs.items()}
    loads = {label: [v for r in fs for k, v in r.items() if k.endswith("load_average_at_start/0")] for label, fs in flat.items()}
    figures: dict[str, Any] = {}
    base_keys, this_keys = set().union(*flat["base"]), set().union(*flat["this"])
    pairs = {key: key for key in base_keys & this_keys}
    for key in this_keys - base_keys:
        for mine, theirs in COUNTERPARTS:
            if mine in key and key.replace(mine, theirs) in base_keys:
                pairs[key] = key.replace(mine, theirs)
    for key in sorted(pairs):
        sign = direction(key)
        if not sign:
            continue
        source = {"base": pairs[key], "this": key}
        values = {label: [r[source[label]] for r in fs if source[label] in r and r[source[label]] > 0] for label, fs in flat.items()}
        if not values["base"] or not values["this"]:
            continue
        best = {label: (max(v) if sign > 0 else min(v)) for label, v in values.items()}
        spread = {label: (max(v) / min(v) if len(v) > 1 else None) for label, v in values.items()}
        speed = best["this"] / best["base"] if sign > 0 else best["base"] / best["this"]
        figures[key] = {"base": best["base"], "this": best["this"], "speed_this_over_base": speed, "spread_within": spread}
        if pairs[key] != key:
            figures[key]["base_figure"] = pairs[key]
    return {"figures": figures, "load_average_at_start": loads, "runs": {label: len(rs) for label, rs in runs.items()}}


def table(report: dict[str, Any]) -> str:
    lines = [f"{'figure':<90} {'base':>12} {'this':>12} {'speed':>7}  spread base / this"]
    for key, f in report["figures"].items():
        s = f["spread_within"]
        spread = " / ".join("-" if v is None else f"{v:.2f}" for v in (s["base"], s["this"]))
        lines.append(f"{key:<90} {f['base']:>12.4g} {f['this']:>12.4g} {f['speed_this_over_base']:>7.2f}  {spread}")
    lines.append(f"load averages at the start of each run: {report['load_average_at_start']}")
    return "\n".join(lines)


if __name__ == "__main__":
    raise SystemExit(main())

"""Campaign files (TOML): what ``freefloat campaign SPEC.toml --out DIR`` reads, and the runs it plans.

A campaign runs one scenario many times with some of its values changed, and records what each run gives.
Schema (docs/campaigns.md)::

    description = "..."                                   # optional
    scenario = "../scenarios/tumbling_satellite_capture.toml"   # a simulation or capture scenario (relative to this file)
    # function = "package.module:name"                    # or a Python function f(parameters: dict) -> dict of results
    # [map] ...                                           # or a singularity-measure / workspace map (.maps)

    [runs]
    count = 64                                            # random draws (per grid point); default 1
    seed = 2026                                           # of numpy's Generator: the same draws every time

    [parameters]                                          # dotted keys into the scenario file; [k] indexes a list
    "payload.mass" = { distribution = "uniform", low = 300.0, high = 700.0 }
    "payload.inertia" = { distribution = "lognormal", median = 187.5, sigma = 0.2 }
    "payload.angular_velocity[2]" = { distribution = "normal", mean = 0.05, std = 0.01 }
    "grasp.joints" = { distribution = "choice", values = ["free", "locked"] }
    "detumble.rate_gain" = { values = [0.25, 0.5, 1.0] }  # a grid axis (or linspace = [start, stop, num])

    [record]
    scalars = ["sequence.detumble.delta_v"]               # dotted paths into the run's result (capture --json, simulate's NAME.json)
    series = ["omega", "v_cm"]                            # trajectory fields kept per run (capture: the detumbling run)
    units = { "sequence.detumble.delta_v" = "m/s" }       # optional: the report's axis units (known names have theirs)

    [summary]
    statistics = ["mean", "std", "min", "p5", "median", "p95", "max"]
    rank_by = "sequence.detumble.delta_v"                 # worst cases: the largest values
    worst = 5                                             # how many worst cases
    # worst_is = "min"                                    # the smallest values are the worst

The runs are the product of the grid axes, times ``runs.count`` random draws at each grid point, drawn at
once with ``numpy.random.default_rng(seed)`` through scipy.stats. Each run has a stable id: a hash of the
campaign's content (this file's table and the scenario's, not their paths) and of the run's index and
values (:func:`plan_runs`). Every error names the field and the fix (:class:`~freefloat.ModelError`).
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..core.errors import ModelError
from ..io.model_files import read_toml
from ..scenarios.scenario import _number, _table, _where
from ._fields import MAX_RUNS, integer_field, plan_estimate
from .maps import map_from_dict, map_runs

__all__ = [
    "COLUMNS",
    "DISTRIBUTIONS",
    "MAX_RUNS",
    "SERIES",
    "STATISTICS",
    "CampaignSpec",
    "Run",
    "campaign_from_dict",
    "get_path",
    "load_campaign",
    "plan_runs",
    "set_path",
]

#: ``distribution`` of a random parameter -> its keys (``choice`` also takes optional weights ``p``).
DISTRIBUTIONS: dict[str, tuple[str, ...]] = {
    "uniform": ("low", "high"),
    "loguniform": ("low", "high"),
    "normal": ("mean", "std"),
    "lognormal": ("median", "sigma"),
    "choice": ("values",),
}
#: Time series a run can record (:class:`~freefloat.Trajectory` fields, time first).
SERIES = (
    "q", "qdot", "omega", "attitude", "r_cm", "v_cm", "joint_torque", "spacecraft_force", "spacecraft_torque",
    "kinetic_energy", "angular_momentum", "linear_momentum", "wheel_angle", "wheel_speed", "wheel_torque",
)  # fmt: skip
#: Summary statistics of ``[summary] statistics``: these, and ``pN`` (the N-th percentile, 0 <= N <= 100).
STATISTICS = ("mean", "std", "min", "median", "max", "count")

#: The columns of every run's row (:mod:`.store`), before the parameters and the recorded scalars.
COLUMNS = ("run_id", "index", "status", "failure", "reason", "seconds", "worker")
_TOP_KEYS = {"description", "scenario", "function", "map", "runs", "parameters", "record", "summary"}
_RUNS_KEYS = {"count", "seed", "max_plan"}
_MORE = "raise the limit with [runs] max_plan = N (the plan is drawn in memory before the first run)"
_RECORD_KEYS = {"scalars", "series", "units"}
_SUMMARY_KEYS = {"statistics", "rank_by", "worst", "worst_is"}
_GRID_KEYS = {"values", "linspace"}
_PATH_PART = re.compile(r"([^.\[\]]+)|\[(\d+)\]")


@dataclass(frozen=True)
class Run:
    """One run of a campaign: its id, its index in the plan and the value of each varied parameter."""

    run_id: str
    index: int
    parameters: dict[str, Any]


@dataclass(frozen=True, eq=False)
class CampaignSpec:
    """A validated campaign. ``kind``: "simulate", "capture", "function" or "map"; ``scenario``: the scenario's
    table (``kind`` simulate / capture) or the ``[map]`` table; ``base``: where its relative paths start."""

    source: str
    kind: str
    scenario: dict[str, Any]
    base: str
    function: str = ""
    description: str = ""
    count: int = 1
    seed: int = 0
    grid: dict[str, list[Any]] = field(default_factory=dict)
    random: dict[str, dict[str, Any]] = field(default_factory=dict)
    scalars: tuple[str, ...] = ()
    series: tuple[str, ...] = ()
    statistics: tuple[str, ...] = ("mean", "std", "min", "p5", "median", "p95", "max")
    rank_by: str = ""
    worst: int = 5
    worst_is: str = "max"
    units: dict[str, str] = field(default_factory=dict)  # of the scalars, for the report (not in the campaign's id)

    @property
    def parameters(self) -> tuple[str, ...]:
        """The varied parameters: grid axes first, then random draws, each in file order."""
        return (*self.grid, *self.random)

    @property
    def campaign_id(self) -> str:
        """A hash of what the runs compute (the scenario's table, the function's name, the parameters, the records),
        not of the files' paths: the same campaign has the same id on any machine."""
        content = {
            "kind": self.kind, "scenario": self.scenario, "function": self.function, "count": self.count, "seed": self.seed,
            "grid": self.grid, "random": self.random, "scalars": self.scalars, "series": self.series,
        }  # fmt: skip
        return _digest(content)[:16]


def _digest(value: Any) -> str:
    return hashlib.sha256(json.dumps(value, sort_keys=True, default=_plain).encode()).hexdigest()


def _plain(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, (tuple, np.ndarray)):
        return list(value)
    raise TypeError(f"cannot hash {value!r}")


# --------------------------------------------------------------------- dotted paths
def _parts(path: str) -> list[str | int]:
    """``"payload.angular_velocity[2]"`` -> ["payload", "angular_velocity", 2]; a malformed path is a ValueError."""
    parts: list[str | int] = []
    pos = 0
    for match in _PATH_PART.finditer(path):
        gap = path[pos : match.start()]
        if gap not in ("", ".") or (gap == "" and match.group(1) and parts):
            raise ValueError(f"malformed path {path!r}")
        parts.append(match.group(1) if match.group(1) is not None else int(match.group(2)))
        pos = match.end()
    if not parts or pos != len(path):
        raise ValueError(f"malformed path {path!r}")
    return parts


def get_path(data: Any, path: str) -> Any:
    """The value at a dotted path (``[k]`` indexes a list); a KeyError naming the missing part and the keys there."""
    node = data
    done: list[str] = []
    for part in _parts(path):
        if isinstance(part, int):
            if not isinstance(node, list) or part >= len(node):
                size = f"a list of {len(node)}" if isinstance(node, list) else "not a list"
                raise KeyError(f"{'.'.join(done) or 'the top'} is {size}, so [{part}] does not exist")
            node = node[part]
            done[-1] += f"[{part}]"
            continue
        if not isinstance(node, dict) or part not in node:
            here = "the top" if not done else ".".join(done)
            keys = sorted(node) if isinstance(node, dict) else []
            import difflib

            close = difflib.get_close_matches(part, [str(k) for k in keys], n=3)
            hint = f" (did you mean {', '.join(close)}?)" if close else ""
            raise KeyError(f"no {part!r} in {here}{hint}; there: {', '.join(map(str, keys)) or 'no keys'}")
        node = node[part]
        done.append(part)
    return node


def set_path(data: dict[str, Any], path: str, value: Any) -> dict[str, Any]:
    """A copy of ``data`` (nested dicts and lists copied along the path) with the value at ``path`` replaced."""
    parts = _parts(path)

    def put(node: Any, k: int) -> Any:
        if k == len(parts):
            return value
        copy: Any = list(node) if isinstance(node, list) else dict(node)
        copy[parts[k]] = put(node[parts[k]], k + 1)
        return copy

    out: dict[str, Any] = put(data, 0)
    return out


# --------------------------------------------------------------------- sections
def _grid_axis(name: str, table: dict[str, Any], source: str, limit: int = MAX_RUNS) -> list[Any]:
    where = f"parameters.{name}"
    table = _table(table, _GRID_KEYS, source, where)
    if len(table) != 1:
        raise ModelError(_where(source, where), "needs one of values, linspace", "give values = [...] or linspace = [start, stop, num]")
    if "values" in table:
        values = table["values"]
        if not isinstance(values, list) or not values:
            raise ModelError(_where(source, f"{where}.values"), f"expected a non-empty list, got {values!r}", "give values = [a, b, ...]")
        return list(values)
    raw = table["linspace"]
    fix = "give linspace = [start, stop, num] with num an integer >= 1"
    if not isinstance(raw, list) or len(raw) != 3 or isinstance(raw[2], bool) or not isinstance(raw[2], int) or raw[2] < 1:
        raise ModelError(_where(source, f"{where}.linspace"), f"expected [start, stop, num], got {raw!r}", fix)
    if raw[2] > limit:
        raise ModelError(_where(source, f"{where}.linspace"), f"num {raw[2]} is above {limit:,} runs ({plan_estimate(raw[2])})", _MORE)
    lo, hi = (_number(v, source, f"{where}.linspace", fix) for v in raw[:2])
    return [float(v) for v in np.linspace(lo, hi, raw[2])]


def _distribution(name: str, table: dict[str, Any], source: str) -> dict[str, Any]:
    where = f"parameters.{name}"
    kind = table.get("distribution")
    if kind not in DISTRIBUTIONS:
        raise ModelError(
            _where(source, f"{where}.distribution"), f"unknown distribution {kind!r}", f"use one of {', '.join(DISTRIBUTIONS)}"
        )
    keys = DISTRIBUTIONS[kind]
    table = _table(table, {"distribution", *keys, *(("p",) if kind == "choice" else ())}, source, where)
    for key in keys:
        if key not in table:
            raise ModelError(_where(source, f"{where}.{key}"), "missing", f"a {kind} distribution needs {', '.join(keys)}")
    if kind == "choice":
        values = table["values"]
        if not isinstance(values, list) or not values:
            raise ModelError(_where(source, f"{where}.values"), f"expected a non-empty list, got {values!r}", "give values = [a, b, ...]")
        out: dict[str, Any] = {"distribution": kind, "values": list(values)}
        if "p" in table:
            p = table["p"]
            fix = f"give {len(values)} weights >= 0 that sum to 1, one per value"
            if not isinstance(p, list) or len(p) != len(values):
                raise ModelError(_where(source, f"{where}.p"), f"expected {len(values)} weights, got {p!r}", fix)
            w = np.array([_number(v, source, f"{where}.p", fix) for v in p])
            if np.any(w < 0) or abs(w.sum() - 1.0) > 1e-9:
                raise ModelError(_where(source, f"{where}.p"), f"weights {p!r} are negative or do not sum to 1", fix)
            out["p"] = w.tolist()
        return out
    out = {"distribution": kind, **{key: _number(table[key], source, f"{where}.{key}", f"give {key}, a number") for key in keys}}
    if kind in ("uniform", "loguniform") and not out["high"] > out["low"] > (0.0 if kind == "loguniform" else -np.inf):
        raise ModelError(_where(source, where), f"needs high > low{' > 0' if kind == 'loguniform' else ''}", "fix low and high")
    for key in {"normal": ("std",), "lognormal": ("median", "sigma")}.get(kind, ()):
        if out[key] <= 0.0:
            raise ModelError(_where(source, f"{where}.{key}"), f"must be positive, got {out[key]!r}", f"give {key} > 0")
    return out


def _draws(table: dict[str, Any], size: int, rng: np.random.Generator) -> list[Any]:
    """``size`` draws of one distribution (scipy.stats with numpy's Generator)."""
    from scipy import stats  # (imported here: not with freefloat)

    kind = table["distribution"]
    if kind == "choice":
        picks = rng.choice(len(table["values"]), size=size, p=table.get("p"))
        return [table["values"][int(k)] for k in picks]
    frozen = {
        "uniform": lambda: stats.uniform(loc=table["low"], scale=table["high"] - table["low"]),
        "loguniform": lambda: stats.loguniform(table["low"], table["high"]),
        "normal": lambda: stats.norm(loc=table["mean"], scale=table["std"]),
        "lognormal": lambda: stats.lognorm(s=table["sigma"], scale=table["median"]),
    }[kind]()
    return [float(v) for v in np.atleast_1d(frozen.rvs(size=size, random_state=rng))]


def _string_list(value: Any, source: str, where: str, fix: str) -> tuple[str, ...]:
    if not isinstance(value, list) or not all(isinstance(v, str) and v for v in value):
        raise ModelError(_where(source, where), f"expected a list of names, got {value!r}", fix)
    return tuple(value)


def _record(table: Any, source: str, kind: str) -> tuple[tuple[str, ...], tuple[str, ...], dict[str, str]]:
    table = _table(table, _RECORD_KEYS, source, "record")
    scalars = _string_list(table.get("scalars", []), source, "record.scalars", 'give scalars = ["path.in.the.result", ...]')
    for name in scalars:
        try:
            _parts(name)
        except ValueError as exc:
            raise ModelError(_where(source, "record.scalars"), str(exc), "write dotted keys such as sequence.detumble.delta_v") from None
    series = _string_list(table.get("series", []), source, "record.series", f"give series = [...] among {', '.join(SERIES)}")
    if kind in ("simulate", "capture"):
        for name in series:
            if name not in SERIES:
                raise ModelError(_where(source, f"record.series.{name}"), "unknown time series", f"use one of {', '.join(SERIES)}")
    if len(set(scalars)) != len(scalars) or len(set(series)) != len(series):
        raise ModelError(_where(source, "record"), "names a quantity twice", "list each quantity once")
    units = table.get("units", {})
    if not isinstance(units, dict) or not all(isinstance(v, str) and v for v in units.values()):
        raise ModelError(
            _where(source, "record.units"), f"expected a table of unit names, got {units!r}", 'e.g. units = { square = "m^2" }'
        )
    for name in units:
        if name not in scalars:
            raise ModelError(
                _where(source, f"record.units.{name}"), "is not a recorded scalar", f"give units of record.scalars: {', '.join(scalars)}"
            )
    return scalars, series, dict(units)


def _summary(table: Any, source: str, scalars: tuple[str, ...]) -> dict[str, Any]:
    table = _table(table, _SUMMARY_KEYS, source, "summary")
    out: dict[str, Any] = {}
    if "statistics" in table:
        names = _string_list(table["statistics"], source, "summary.statistics", f"use {', '.join(STATISTICS)} or pN (a percentile)")
        for name in names:
            if name not in STATISTICS and not (re.fullmatch(r"p\d+(\.\d+)?", name) and float(name[1:]) <= 100.0):
                raise ModelError(_where(source, "summary.statistics"), f"unknown statistic {name!r}", f"use {', '.join(STATISTICS)} or pN")
        out["statistics"] = names
    if "rank_by" in table:
        rank = table["rank_by"]
        if rank not in scalars:
            raise ModelError(
                _where(source, "summary.rank_by"), f"{rank!r} is not recorded", f"give one of record.scalars: {', '.join(scalars)}"
            )
        out["rank_by"] = rank
    if "worst" in table:
        out["worst"] = integer_field(table, "worst", 5, 1, source, "summary", "e.g. worst = 5")
    if "worst_is" in table:
        if table["worst_is"] not in ("max", "min"):
            raise ModelError(
                _where(source, "summary.worst_is"), f"unknown value {table['worst_is']!r}", 'write "max" (the largest are worst) or "min"'
            )
        out["worst_is"] = table["worst_is"]
    return out


def _scenario(top: dict[str, Any], source: str, base: Path) -> tuple[str, dict[str, Any], str]:
    """(kind, the scenario's table, its folder) of ``scenario = PATH``."""
    path = top["scenario"]
    if not isinstance(path, str) or not path:
        raise ModelError(
            _where(source, "scenario"), f"expected a path, got {path!r}", "give the scenario file, relative to the campaign file"
        )
    file = base / path
    if not file.is_file():
        raise ModelError(_where(source, "scenario"), f"no scenario file {file}", "give the scenario file, relative to the campaign file")
    data = read_toml(file, "scenario")
    kind = "capture" if "payload" in data else "simulate"
    return kind, data, str(file.parent.resolve())


def campaign_from_dict(data: Any, *, source: str = "", base: Path | None = None) -> CampaignSpec:
    """Validate a campaign given as a dict (a parsed TOML file); ``base``: the folder of relative paths."""
    base = Path(".") if base is None else base
    top = _table(data, _TOP_KEYS, source, "")
    given = [k for k in ("scenario", "function", "map") if k in top]
    if len(given) != 1:
        problem = "missing" if not given else f"given together with {given[1]}"
        raise ModelError(
            _where(source, given[0] if given else "scenario"), problem, "give one of scenario = PATH, function = 'module:name', [map]"
        )
    if given[0] == "scenario":
        kind, scenario, where = _scenario(top, source, base)
    elif given[0] == "map":
        kind, scenario, where = "map", map_from_dict(top["map"], source, base), str(base.resolve())
    else:
        function = top["function"]
        if not isinstance(function, str) or not re.fullmatch(r"[\w.]+:\w+", function):
            raise ModelError(
                _where(source, "function"), f"expected 'module:name', got {function!r}", "e.g. function = 'mypackage.runs:run'"
            )
        kind, scenario, where = "function", {}, str(base.resolve())
    runs = _table(top.get("runs", {}), _RUNS_KEYS, source, "runs")
    values = {"count": integer_field(runs, "count", 1, 1, source, "runs", "e.g. count = 64")}
    limit = integer_field(runs, "max_plan", MAX_RUNS, 1, source, "runs", f"e.g. max_plan = {2 * MAX_RUNS}")
    if values["count"] > limit:
        raise ModelError(
            _where(source, "runs.count"),
            f"{values['count']:,} runs are above the {limit:,} a campaign can plan ({plan_estimate(values['count'])})",
            f"split it into campaigns of fewer runs (another seed each), or {_MORE}",
        )
    values["seed"] = integer_field(runs, "seed", 0, 0, source, "runs", "e.g. seed = 2026")
    grid: dict[str, list[Any]] = {}
    random: dict[str, dict[str, Any]] = {}
    if kind == "map" and top.get("parameters"):
        raise ModelError(
            _where(source, "parameters"),
            "a map varies the configurations, chunk by chunk",
            "drop [parameters]; set [map] samples and chunk",
        )
    for name, table in _table(top.get("parameters", {}), set(top.get("parameters", {})), source, "parameters").items():
        where = f"parameters.{name}"
        try:
            _parts(name)
            if kind != "function":
                current = get_path(scenario, name)
        except ValueError as exc:
            raise ModelError(
                _where(source, where), str(exc), "write dotted keys such as payload.mass or payload.angular_velocity[2]"
            ) from None
        except KeyError as exc:
            fix = "vary a value the scenario file gives (add it to the scenario first)"
            raise ModelError(_where(source, where), f"unknown parameter: the scenario has no such key ({exc.args[0]})", fix) from None
        if kind != "function" and isinstance(current, (dict, list)):
            raise ModelError(_where(source, where), "is a table or a list, not a value", f"vary one entry, e.g. {name}[0] or {name}.key")
        if not isinstance(table, dict):
            raise ModelError(
                _where(source, where), f"expected a table, got {table!r}", "give { distribution = ..., ... } or { values = [...] }"
            )
        if "distribution" in table:
            random[name] = _distribution(name, table, source)
        else:
            grid[name] = _grid_axis(name, table, source, limit)
    total = math.prod(len(axis) for axis in grid.values()) * values["count"]
    if total > limit:
        sizes = " x ".join([*(str(len(axis)) for axis in grid.values()), *([str(values["count"])] if values["count"] > 1 else [])])
        raise ModelError(
            _where(source, "parameters"),
            f"plans {sizes} = {total:,} runs, above the {limit:,} a campaign can plan ({plan_estimate(total)})",
            f"give fewer grid values or a smaller runs.count, split it into campaigns, or {_MORE}",
        )
    if values["count"] > 1 and not random:
        raise ModelError(
            _where(source, "runs.count"),
            f"is {values['count']} but no parameter is drawn at random",
            "drop runs.count or add a distribution",
        )
    scalars, series, units = _record(top.get("record", {}), source, kind)
    for name in scalars:
        if name in grid or name in random or name in COLUMNS:
            fix = "record another quantity, or vary the parameter under another name"
            raise ModelError(
                _where(source, "record.scalars"), f"{name!r} is also a column of the results (a parameter or {', '.join(COLUMNS)})", fix
            )
    summary = _summary(top.get("summary", {}), source, scalars)
    description = top.get("description", "")
    if not isinstance(description, str):
        raise ModelError(_where(source, "description"), f"expected a string, got {description!r}", "write the description in quotes")
    return CampaignSpec(
        source=source,
        kind=kind,
        scenario=scenario,
        base=where,
        function=top.get("function", ""),
        description=description,
        count=values["count"],
        seed=values["seed"],
        grid=grid,
        random=random,
        scalars=scalars,
        series=series,
        units=units,
        **summary,
    )


def load_campaign(path: str | Path) -> CampaignSpec:
    """Read and validate a campaign TOML file (schema in the module docstring and docs/campaigns.md)."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: is not a file; give a campaign TOML file" if path.exists() else f"{path}: no such campaign file")
    return campaign_from_dict(read_toml(path, "campaign"), source=str(path), base=path.parent)


def plan_runs(spec: CampaignSpec) -> list[Run]:
    """Every run of the campaign, in order: the grid's product (last axis fastest), ``count`` draws at each point.

    The draws are made at once (``default_rng(seed)``, one parameter after the other), so the plan, and each
    run's id, is the same on every machine and after a resume.
    """
    campaign = spec.campaign_id  # (a hash of the whole campaign: once, not once per run)
    if spec.kind == "map":
        return [Run(_run_id(campaign, i, params), i, params) for i, params in enumerate(map_runs(spec.scenario))]
    points = list(itertools.product(*spec.grid.values())) or [()]
    total = len(points) * spec.count
    rng = np.random.default_rng(spec.seed)
    drawn = {name: _draws(table, total, rng) for name, table in spec.random.items()}
    runs = []
    for i in range(total):
        params = dict(zip(spec.grid, points[i // spec.count], strict=True))
        params.update({name: values[i] for name, values in drawn.items()})
        runs.append(Run(_run_id(campaign, i, params), i, params))
    return runs


def _run_id(campaign_id: str, index: int, params: dict[str, Any]) -> str:
    return _digest({"campaign": campaign_id, "index": index, "parameters": params})[:16]

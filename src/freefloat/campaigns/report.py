"""Reports of a campaign: summary statistics, failures, worst cases, sensitivities; tables and plots.

:func:`summarize_campaign` computes (from the stored runs only); :class:`CampaignSummary` renders
(:meth:`~CampaignSummary.markdown`, :meth:`~CampaignSummary.as_dict`) and draws
(:meth:`~CampaignSummary.plot_distributions`, :meth:`~CampaignSummary.plot_failures`,
:meth:`~CampaignSummary.plot_sensitivity`, :meth:`~CampaignSummary.plot_map`), each on axes it is given or a new
figure. :func:`write_campaign_report` writes ``DIR/report/summary.md``, ``summary.json`` and the PNGs.

- statistics of each recorded scalar over the runs that finished "ok" (NaN values, such as a time to rest never
  reached, are left out and counted);
- the failure rate, and the failures grouped by pattern (reasons that differ only by numbers, run ids or addresses
  are one pattern) with their count, whose failure it is ("run": the run's own; "worker": it killed its worker on
  each try) and an example;
- the worst cases: the ``worst`` runs with the largest (or smallest, ``worst_is = "min"``) ``rank_by``, with
  their parameters;
- the sensitivity of each output to each numeric input: Spearman's rank correlation (scipy.stats.spearmanr),
  NaN where an input or output does not vary.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .maps import MAP_SERIES, radius_bound
from .spec import CampaignSpec
from .store import read_runs, read_series

__all__ = ["CampaignSummary", "failure_pattern", "map_totals", "scalar_unit", "summarize_campaign", "write_campaign_report"]

#: The unit of a recorded scalar from the names in its path (searched from the last part back): exact names first,
#: then endings. A scalar none of them names has no unit on its axis ("unit not known"); ``[record] units`` says it.
_UNITS = {
    "delta_v": "m/s", "time_to_rest": "s", "rest_after_grasp": "s", "t_end": "s", "duration": "s", "seconds": "s", "energy_lost": "J",
    "kinetic_energy": "J", "angular_momentum_change": "N m s", "linear_momentum_change": "N s", "angular_momentum": "N m s",
    "linear_momentum": "N s", "mass": "kg", "inertia": "kg m^2", "omega": "rad/s", "angular_velocity": "rad/s",
    "v_cm": "m/s", "velocity": "m/s", "r_cm": "m", "approach_distance": "m", "distance": "m", "radius": "m",
    "joint_torque": "N m", "spacecraft_torque": "N m", "spacecraft_force": "N", "impulse": "N s", "wheel_speed": "rad/s",
    "wheel_angle": "rad", "saturated_fraction": "unitless", "singular_fraction": "unitless", "configurations": "count",
    "singular": "count",
}  # fmt: skip
_ENDINGS = (("_deg", "deg"), ("_s", "s"), ("_m", "m"), ("_kg", "kg"), ("_radius_min", "m"), ("_radius_max", "m"),
            ("radius_min", "m"), ("radius_max", "m"), ("_fraction", "unitless"))  # fmt: skip
_NUMBER = re.compile(r"(?<![\w.])[-+]?(?:\d+(?:\.\d+)*\.?|\.\d+)(?:[eE][-+]?\d+)?(?!\w)|\b[0-9a-f]{16}\b|0x[0-9a-fA-F]+")

REPORT_FILES = ("summary.md", "summary.json", "distributions.png", "failures.png", "sensitivity.png")


@dataclass(frozen=True, eq=False)
class CampaignSummary:
    """The summary of a campaign's stored runs (module docstring). ``values``: each scalar over the ok runs (NaN
    kept); ``inputs``: each numeric parameter over the same runs; ``sensitivity[output][input]``: Spearman's rho."""

    campaign_id: str
    source: str
    description: str
    planned: int
    finished: int
    ok: int
    failed: int
    reasons: dict[str, int]
    failure_groups: list[dict[str, Any]]
    statistics: dict[str, dict[str, float]]
    values: dict[str, np.ndarray]
    inputs: dict[str, np.ndarray]
    sensitivity: dict[str, dict[str, float]]
    rank_by: str
    worst_is: str
    worst: list[dict[str, Any]]
    totals: dict[str, Any] = field(default_factory=dict)
    units: dict[str, str] = field(default_factory=dict)

    @property
    def failure_rate(self) -> float:
        """Failed runs over finished runs (0 when none finished)."""
        return self.failed / self.finished if self.finished else 0.0

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready (NaN as null)."""
        return _json_ready(
            {
                "campaign_id": self.campaign_id,
                "source": self.source,
                "description": self.description,
                "planned": self.planned,
                "finished": self.finished,
                "ok": self.ok,
                "failed": self.failed,
                "failure_rate": self.failure_rate,
                "failure_reasons": self.reasons,
                "failures": self.failure_groups,
                "units": self.units,
                "statistics": self.statistics,
                "sensitivity_spearman": self.sensitivity,
                "rank_by": self.rank_by,
                "worst_is": self.worst_is,
                "worst": self.worst,
                **({"map": self.totals} if self.totals else {}),
            }
        )

    def markdown(self) -> str:
        """The summary as Markdown tables."""
        lines = [f"# Campaign {self.campaign_id}", ""]
        if self.description:
            lines += [self.description, ""]
        lines += [
            f"Source: `{self.source}`. Runs: {self.finished} of {self.planned} finished: {self.ok} ok, {self.failed} failed "
            f"(failure rate {100.0 * self.failure_rate:.3g} %).",
            "",
        ]
        if self.statistics:
            names = list(next(iter(self.statistics.values())))
            lines += ["## Recorded quantities (ok runs)", "", "| quantity | " + " | ".join(names) + " |", "|---" * (len(names) + 1) + "|"]
            lines += [f"| {q} | " + " | ".join(_cell(s[n]) for n in names) + " |" for q, s in self.statistics.items()]
            lines.append("")
        if self.failure_groups:
            lines += ["## Failures", "", "(# stands for a number that differs between runs)", ""]
            lines += ["| runs | whose | reason | example |", "|---|---|---|---|"]
            lines += [
                f"| {g['runs']} | {g['failure']} | {g['pattern'].replace('|', '/')} | {g['example'].replace('|', '/')} |"
                for g in self.failure_groups
            ]
            lines.append("")
        if self.worst:
            params = [k for k in self.worst[0] if k not in ("run_id", self.rank_by)]
            word = "largest" if self.worst_is == "max" else "smallest"
            lines += [f"## Worst cases: the {word} {self.rank_by}", "", "| run_id | " + " | ".join([self.rank_by, *params]) + " |"]
            lines.append("|---" * (len(params) + 2) + "|")
            lines += [f"| {w['run_id']} | " + " | ".join(_cell(w[k]) for k in [self.rank_by, *params]) + " |" for w in self.worst]
            lines.append("")
        if self.sensitivity and self.inputs:
            inputs = list(self.inputs)
            lines += ["## Sensitivity (Spearman rank correlation, output against input)", ""]
            lines += ["| output | " + " | ".join(inputs) + " |", "|---" * (len(inputs) + 1) + "|"]
            lines += [f"| {o} | " + " | ".join(_cell(row[i]) for i in inputs) + " |" for o, row in self.sensitivity.items()]
            lines.append("")
        if self.totals:
            t = self.totals
            lines += ["## Map totals", ""] + [f"- {k}: {_cell(v)}" for k, v in t.items() if not isinstance(v, list)] + [""]
        return "\n".join(lines)

    def plot_distributions(self, fig: Any = None) -> list[Any]:
        """A histogram of each recorded scalar over the ok runs, one axes each; returns the axes."""
        fig = fig if fig is not None else _figure((7.0, 2.4 * max(len(self.values), 1)))
        axes = fig.subplots(max(len(self.values), 1), 1, squeeze=False)[:, 0]
        for ax, (name, values) in zip(axes, self.values.items(), strict=False):
            finite = values[np.isfinite(values)]
            ax.hist(finite, bins=min(50, max(5, finite.size // 4)), color="C0")
            unit = self.units.get(name, "unit not known")
            ax.set_xlabel(f"{name} ({unit})")
            ax.set_ylabel("runs")
            if finite.size < values.size:
                ax.set_title(f"{values.size - finite.size} runs without a value", fontsize="small")
        return list(axes)

    def plot_failures(self, ax: Any = None) -> Any:
        """Runs ok and failed, and the count of each failure reason (bars); returns the axes."""
        ax = ax if ax is not None else _figure((7.0, 3.0)).add_subplot()
        labels = ["ok", *(r[:40] + ("…" if len(r) > 40 else "") for r in self.reasons)]
        counts = [self.ok, *self.reasons.values()]
        ax.barh(range(len(labels)), counts, color=["C2", *["C3"] * len(self.reasons)])
        ax.set_yticks(range(len(labels)), labels, fontsize="x-small")
        ax.invert_yaxis()
        ax.set_xlabel("runs")
        ax.set_title(f"failure rate {100.0 * self.failure_rate:.3g} % of {self.finished} runs", fontsize="medium")
        return ax

    def plot_sensitivity(self, ax: Any = None) -> Any:
        """Spearman's rho of each output (rows) against each input (columns), -1..1; returns the axes."""
        ax = ax if ax is not None else _figure((7.0, 1.0 + 0.5 * max(len(self.sensitivity), 1))).add_subplot()
        outputs, inputs = list(self.sensitivity), list(self.inputs)
        grid = np.array([[self.sensitivity[o][i] for i in inputs] for o in outputs], dtype=float).reshape(len(outputs), len(inputs))
        image = ax.imshow(grid, cmap="coolwarm", vmin=-1.0, vmax=1.0, aspect="auto")
        ax.set_xticks(range(len(inputs)), inputs, rotation=30, ha="right", fontsize="x-small")
        ax.set_yticks(range(len(outputs)), outputs, fontsize="x-small")
        for (r, c), value in np.ndenumerate(grid):
            ax.text(c, r, _cell(value), ha="center", va="center", fontsize="x-small")
        ax.figure.colorbar(image, ax=ax, label="Spearman rho")
        return ax

    def plot_map(self, fig: Any = None) -> list[Any]:
        """A map campaign: counts of |r_E| against log10 |measure| over every chunk, and the |r_E| histogram (all,
        singular); returns the two axes."""
        fig = fig if fig is not None else _figure((7.0, 6.0))
        top, bottom = fig.subplots(2, 1)
        t = self.totals
        grid = np.asarray(t["map"], dtype=float)
        edges, decades = t["radius_edges"], t["measure_decades"]
        top.imshow(np.log10(1.0 + grid.T), origin="lower", aspect="auto", extent=(edges[0], edges[-1], *decades), cmap="viridis")
        top.set_xlabel("|r_E| about the system CM (m)")
        top.set_ylabel("log10 |measure|")
        top.set_title(f"{t['configurations']:.4g} configurations (colour: log10(1 + count))", fontsize="medium")
        centres = 0.5 * (np.asarray(edges[1:]) + np.asarray(edges[:-1]))
        bottom.step(centres, t["radius_histogram"], where="mid", label="all")
        bottom.step(centres, t["singular_radius_histogram"], where="mid", label="singular")
        bottom.set_yscale("symlog")
        bottom.set_xlabel("|r_E| (m)")
        bottom.set_ylabel("configurations")
        bottom.legend(fontsize="small")
        return [top, bottom]


def failure_pattern(reason: str) -> str:
    """``reason`` with what differs from run to run (numbers, run ids, hexadecimal addresses) as ``#``."""
    return _NUMBER.sub("#", reason)


def scalar_unit(name: str, given: dict[str, str] | None = None) -> str:
    """The unit of a recorded scalar (``given``: the campaign's ``[record] units``), "unit not known" otherwise."""
    if given and name in given:
        return given[name]
    parts = [p for p in re.split(r"[.\[\]]", name) if p and not p.isdigit()]
    for part in reversed(parts):
        if part in _UNITS:
            return _UNITS[part]
        for ending, unit in _ENDINGS:
            if part.endswith(ending):
                return unit
    if parts and parts[-1] == "q":
        return "rad (m for a sliding joint)"
    return "unit not known"


def _figure(size: tuple[float, float]) -> Any:
    from matplotlib.figure import Figure

    return Figure(figsize=size, layout="constrained")


def _cell(value: Any) -> str:
    if isinstance(value, float):
        return "—" if math.isnan(value) else f"{value:.6g}"
    return str(value)


def _json_ready(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _json_ready(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_json_ready(v) for v in value]
    if isinstance(value, (float, np.floating)):
        return None if not np.isfinite(value) else float(value)
    if isinstance(value, np.integer):
        return int(value)
    return value


def _statistic(values: np.ndarray, name: str) -> float:
    if name == "count":
        return float(values.size)
    if values.size == 0:
        return math.nan
    if name.startswith("p"):
        return float(np.percentile(values, float(name[1:])))
    reduce: Any = {"mean": np.mean, "std": np.std, "min": np.min, "median": np.median, "max": np.max}[name]
    return float(reduce(values))


def _spearman(x: np.ndarray, y: np.ndarray) -> float:
    from scipy.stats import spearmanr

    keep = np.isfinite(x) & np.isfinite(y)
    if keep.sum() < 3 or np.ptp(x[keep]) == 0.0 or np.ptp(y[keep]) == 0.0:
        return math.nan
    return float(spearmanr(x[keep], y[keep]).statistic)


def map_totals(out: str | Path, spec: CampaignSpec, run_ids: list[str], scalars: dict[str, np.ndarray]) -> dict[str, Any]:
    """A map campaign's chunks summed: the histograms and the map, the extremes, the singular fraction."""
    from .maps import _model

    sums: dict[str, np.ndarray] = {}
    for run_id in run_ids:
        for name, values in read_series(out, run_id).items():
            if name in MAP_SERIES:
                sums[name] = sums.get(name, 0) + values
    bins = spec.scenario["bins"]
    top = radius_bound(_model(spec.scenario["model"], spec.base))
    configurations = float(np.sum(scalars["configurations"]))
    singular = scalars["singular_radius_min"][np.isfinite(scalars["singular_radius_min"])]
    from .maps import MEASURE_DECADES

    return {
        "configurations": configurations,
        "radius_min": float(np.min(scalars["radius_min"])),
        "radius_max": float(np.max(scalars["radius_max"])),
        "measure_abs_min": float(np.min(scalars["measure_abs_min"])),
        "singular_fraction": float(np.sum(scalars["singular"]) / configurations) if configurations else math.nan,
        "singular_radius_min": float(np.min(singular)) if singular.size else math.nan,
        "singular_radius_max": float(np.nanmax(scalars["singular_radius_max"])) if singular.size else math.nan,
        "radius_edges": np.linspace(0.0, top, bins + 1).tolist(),
        "measure_decades": list(MEASURE_DECADES),
        **{name: np.asarray(sums.get(name, np.zeros(0))).tolist() for name in MAP_SERIES},
    }


def summarize_campaign(out: str | Path, spec: CampaignSpec) -> CampaignSummary:
    """The summary of the runs stored in ``out`` (module docstring)."""
    from .maps import MAP_SCALARS
    from .spec import plan_runs

    table = read_runs(out)
    columns = {name: table.column(name).to_numpy(zero_copy_only=False) for name in table.column_names}
    status = columns["status"].astype(str)
    ok = status == "ok"
    groups: dict[tuple[str, str], dict[str, Any]] = {}
    for reason, whose in zip(columns["reason"][~ok], columns["failure"][~ok], strict=True):
        group_key = (str(whose), failure_pattern(str(reason)))
        group = groups.setdefault(group_key, {"pattern": group_key[1], "runs": 0, "failure": group_key[0], "example": str(reason)})
        group["runs"] += 1
    failure_groups = sorted(groups.values(), key=lambda g: -g["runs"])
    reasons: dict[str, int] = {}
    for group in failure_groups:
        reasons[group["pattern"]] = reasons.get(group["pattern"], 0) + group["runs"]
    scalars = MAP_SCALARS if spec.kind == "map" else spec.scalars
    values = {name: np.asarray(columns[name][ok], dtype=float) for name in scalars}
    statistics = {name: {s: _statistic(v[np.isfinite(v)], s) for s in spec.statistics} for name, v in values.items()}
    inputs = {
        name: np.asarray(columns[name][ok], dtype=float)
        for name in spec.parameters
        if columns[name].dtype.kind in "iuf" and spec.kind != "map"
    }
    sensitivity = {o: {i: _spearman(x, y) for i, x in inputs.items()} for o, y in values.items()} if inputs else {}
    rank_by = spec.rank_by or (scalars[0] if scalars and spec.kind != "map" else "")  # (a map's chunks have no worst)
    worst: list[dict[str, Any]] = []
    if rank_by:
        key = values[rank_by]
        order = [k for k in np.argsort(-key if spec.worst_is == "max" else key, kind="stable") if np.isfinite(key[k])][: spec.worst]
        ids = columns["run_id"][ok]
        worst = [{"run_id": str(ids[k]), rank_by: float(key[k]), **{p: _plain(columns[p][ok][k]) for p in spec.parameters}} for k in order]
    totals = map_totals(out, spec, [str(r) for r in columns["run_id"][ok]], values) if spec.kind == "map" and ok.any() else {}
    return CampaignSummary(
        campaign_id=spec.campaign_id,
        source=spec.source,
        description=spec.description,
        planned=len(plan_runs(spec)),
        finished=int(status.size),
        ok=int(ok.sum()),
        failed=int((~ok).sum()),
        reasons=reasons,
        failure_groups=failure_groups,
        statistics=statistics,
        values=values,
        inputs=inputs,
        sensitivity=sensitivity,
        rank_by=rank_by,
        worst_is=spec.worst_is,
        worst=worst,
        totals=totals,
        units={name: scalar_unit(name, spec.units) for name in scalars},
    )


def _plain(value: Any) -> Any:
    return value.item() if isinstance(value, np.generic) else value


def write_campaign_report(summary: CampaignSummary, out: str | Path, *, dpi: int = 110) -> list[Path]:
    """``out/report/``: summary.md, summary.json and the plots (a map campaign: map.png too); the paths written.
    The folder is the campaign's own: its files are replaced each time."""
    folder = Path(out) / "report"
    folder.mkdir(exist_ok=True)
    written = [folder / "summary.md", folder / "summary.json"]
    written[0].write_text(summary.markdown(), encoding="utf-8")
    written[1].write_text(json.dumps(summary.as_dict(), indent=2) + "\n", encoding="utf-8")
    plots: list[tuple[str, Any]] = [("failures.png", lambda: summary.plot_failures().figure)]
    if summary.values:
        plots.append(("distributions.png", lambda: summary.plot_distributions()[0].figure))
    if summary.sensitivity:
        plots.append(("sensitivity.png", lambda: summary.plot_sensitivity().figure))
    if summary.totals:
        plots.append(("map.png", lambda: summary.plot_map()[0].figure))
    for name, draw in plots:
        draw().savefig(folder / name, dpi=dpi)
        written.append(folder / name)
    return written

"""The workspace limits of a model, end effector by end effector: what ``freefloat workspace`` prints and plots.

:func:`workspace_limits` computes, for each chosen end effector, the
reachable workspace (1992 eq. 15), the guaranteed workspace (eq. 16) and,
where requested, the path-independent / path-dependent workspaces (eq. 17),
all about the system CM in m (:mod:`freefloat.analysis.workspace`). The result
renders as text (:meth:`WorkspaceLimits.render_text`), as a JSON-ready dict
(:meth:`WorkspaceLimits.as_dict`) and as figures
(:func:`write_workspace_plots`; matplotlib object API, no pyplot state).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..core.feedback import status
from ..core.model import Model
from ._workspace_reach import guaranteed_workspace, reachable_workspace
from ._workspace_results import GuaranteedWorkspace, PathIndependentWorkspace, ReachableWorkspace
from ._workspace_singular import path_independent_workspace
from .singularity import SingularityCriterion
from .workspace_3d import plot_workspace_sections, workspace_cloud

__all__ = ["WorkspaceLimits", "limits_json", "system_jacobian_is_square", "workspace_limits", "write_workspace_plots"]


def system_jacobian_is_square(model: Model) -> bool:
    """True when the system J* used for dynamic singularities (eq. 17) is square, so det J* exists.

    Rows: [v_x, v_y] per end effector for a planar model, all six otherwise.
    """
    rows = (2 if model.is_planar else 6) * model.n_end_effectors
    return rows == model.n_joints


def _intervals(values: Sequence[tuple[float, float]]) -> list[list[float]]:
    return [[float(lo), float(hi)] for lo, hi in values]


def _fmt_intervals(values: Sequence[tuple[float, float]]) -> str:
    return " ∪ ".join(f"[{lo:.6f}, {hi:.6f}]" for lo, hi in values) if values else "none"


@dataclass(frozen=True, eq=False)
class WorkspaceLimits:
    """Workspace limits of some end effectors of one model (all radii in m about the system CM).

    ``reachable``, ``guaranteed`` and ``piw``: one entry per name in
    ``end_effectors``; ``piw`` entries are None when the PIW was not
    computed, and ``piw_note`` says why.
    """

    model: Model
    end_effectors: tuple[str, ...]
    reachable: tuple[ReachableWorkspace, ...]
    guaranteed: tuple[GuaranteedWorkspace, ...]
    piw: tuple[PathIndependentWorkspace | None, ...]
    piw_note: str = ""
    criterion: SingularityCriterion | None = None

    def as_dict(self) -> dict[str, Any]:
        """A JSON-ready summary (floats, lists, None); radii in m."""
        payload = float(sum(float(p.get("mass", 0.0)) for p in self.model.payloads))
        out: dict[str, Any] = {
            "model": self.model.name,
            "total_mass": self.model.total_mass,
            "payload_mass": payload,
            "units": "m, about the system CM",
            "piw_note": self.piw_note,
            "end_effectors": [],
        }
        for name, reach, gw, piw in zip(self.end_effectors, self.reachable, self.guaranteed, self.piw, strict=True):
            entry: dict[str, Any] = {
                "name": name,
                "reachable": {"R_min": reach.R_min, "R_max": reach.R_max, "method": reach.method, "accuracy": reach.accuracy},
                "guaranteed": {
                    "exists": gw.exists,
                    "R_min": gw.R_min,
                    "R_max": gw.R_max,
                    "reason": gw.reason,
                    "method": gw.method,
                    "accuracy": gw.accuracy,
                },
                "piw": None,
            }
            if piw is not None:
                entry["piw"] = {
                    "R_min": piw.R_min,
                    "R_max": piw.R_max,
                    "intervals": _intervals(piw.piw),
                    "pdw": _intervals(piw.pdw),
                    "method": piw.method,
                    "criterion": piw.criterion,
                    "accuracy": piw.accuracy,
                    "resolution": piw.resolution,
                    "samples": piw.samples,
                }
            out["end_effectors"].append(entry)
        return out

    def render_text(self) -> str:
        """The limits table as plain text."""
        m = self.model
        payload = sum(float(p.get("mass", 0.0)) for p in m.payloads)
        lines = [
            f"{m.name}: workspaces about the system CM (m), Papadopoulos 1992 eqs. 15-17",
            f"total mass {m.total_mass:.6g} kg" + (f" (payload {payload:.6g} kg)" if payload else ""),
        ]
        for name, reach, gw, piw in zip(self.end_effectors, self.reachable, self.guaranteed, self.piw, strict=True):
            lines += [
                "",
                name,
                f"  reachable  (eq. 15)  R_min  {reach.R_min:.6f}  R_max  {reach.R_max:.6f}   "
                f"{reach.method}, accuracy {reach.accuracy:.1e} m",
            ]
            if gw.exists and gw.R_min is not None and gw.R_max is not None:
                lines.append(
                    f"  guaranteed (eq. 16)  R'_min {gw.R_min:.6f}  R'_max {gw.R_max:.6f}   {gw.method}, accuracy {gw.accuracy:.1e} m"
                )
            else:
                lines.append(f"  guaranteed (eq. 16)  does not exist: {gw.reason}")
            if piw is None:
                lines.append(f"  PIW        (eq. 17)  not computed: {self.piw_note}")
                continue
            if piw.R_min is None or piw.R_max is None:
                head = "none: every reachable radius is reached in some singular configuration"
            else:
                head = f"[{piw.R_min:.6f}, {piw.R_max:.6f}] (widest); all: {_fmt_intervals(piw.piw)}"
            lines += [
                f"  PIW        (eq. 17)  {head}",
                f"  PDW                  {_fmt_intervals(piw.pdw)}",
                f"  singular where       {piw.criterion}",
                f"  PIW method           {piw.method}; {piw.samples} configurations; accuracy {piw.accuracy:.1e} m, "
                f"resolution {piw.resolution:.1e} m",
            ]
        return "\n".join(lines) + "\n"


def workspace_limits(
    model: Model,
    end_effectors: Sequence[str | int] | None = None,
    *,
    piw: bool | None = None,
    samples: int = 1 << 16,
    criterion: SingularityCriterion | None = None,
) -> WorkspaceLimits:
    """Reachable, guaranteed and path-independent workspaces of the chosen end effectors (default: all).

    ``piw``: compute the PIW/PDW (eq. 17) too; None (default) computes them
    when the system J* is square (det J* exists, as in the paper), and skips
    them otherwise (a non-square J* is searched by its smallest singular
    value: minutes for a 7-joint arm). ``samples``: configurations sampled
    for the PIW. ``criterion``: which rows of J* and which measure count as
    singular for the PIW (:class:`~freefloat.analysis.singularity.SingularityCriterion`;
    default the paper's); a threshold that makes every configuration singular (at or above
    :meth:`~freefloat.analysis.singularity.SingularityCriterion.measure_bound`) is a ValueError,
    even when the PIW is not computed. Unknown end effectors raise :class:`~freefloat.UnknownNameError`.

    Progress: each step ("[3/6] PIW of arm1_ee (65,536 samples)") shows a spinner with its elapsed time on a terminal,
    and the PIW sampling a bar with the count of configurations; outside a terminal the same goes to the
    ``freefloat.progress`` logger (a line when a step starts, the count every 10 s, the duration of a step over 1 s).
    """
    if model.n_end_effectors == 0:
        raise ValueError(
            f"model {model.name!r} has no end effectors (no arm: {model.n_joints} joints); a workspace needs one "
            "(every leaf body of the tree is an end effector: add an arm)"
        )
    chosen = list(range(model.n_end_effectors)) if not end_effectors else [model.end_effector_index(e) for e in end_effectors]
    if len(set(chosen)) != len(chosen):
        raise ValueError(f"end_effectors: each end effector once, got {list(end_effectors or [])!r}")
    crit = criterion if criterion is not None else SingularityCriterion()
    crit.check_threshold(model)  # a threshold that makes every configuration singular: refused before the work
    square = crit.square(model) and crit.threshold == 0.0
    do_piw = square if piw is None else bool(piw)
    note = ""
    if not do_piw:
        note = (
            "J* is not square (det J* undefined; searching its smallest singular value is slow) or a threshold is set: "
            "pass --piw to compute it"
            if piw is None
            else "not requested"
        )
    steps = len(chosen) * (3 if do_piw else 2)
    done = iter(range(1, steps + 1))
    reach_list: list[ReachableWorkspace] = []
    gws_list: list[GuaranteedWorkspace] = []
    piws: list[PathIndependentWorkspace | None] = []
    for e in chosen:
        name = model.end_effector_names[e]
        with status(f"[{next(done)}/{steps}] reachable workspace of {name}"):
            reach_list.append(reachable_workspace(model, e))
        with status(f"[{next(done)}/{steps}] guaranteed workspace of {name}"):
            gws_list.append(guaranteed_workspace(model, e))
        if not do_piw:
            piws.append(None)
            continue
        with status(f"[{next(done)}/{steps}] PIW of {name} ({samples:,} samples)"):
            piws.append(path_independent_workspace(model, e, samples=samples, reachable=reach_list[-1], criterion=crit))
    reach, gws = tuple(reach_list), tuple(gws_list)
    return WorkspaceLimits(
        model=model,
        end_effectors=tuple(model.end_effector_names[e] for e in chosen),
        reachable=reach,
        guaranteed=gws,
        piw=tuple(piws),
        piw_note=note,
        criterion=crit,
    )


def _slug(name: str) -> str:
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in name)


def write_workspace_plots(limits: WorkspaceLimits, out: Path, *, dpi: int = 200, cloud_samples: int = 1 << 13) -> list[Path]:
    """One PNG per end effector (reachable, guaranteed, PIW/PDW about the system CM) in ``out``.

    Distances are |r_E| (attitude-free), so each workspace is a shell about
    the CM. A planar model is drawn as annuli in its plane, like the 1992
    paper's Figs. 4 and 7; a spatial model as the shells' sections by the xy,
    xz and yz planes through the CM with the points reached near each plane,
    and a 3D cloud of ``cloud_samples`` end-effector positions coloured by the
    singularity measure (:mod:`freefloat.analysis.workspace_3d`). Returns the written paths.
    """
    from matplotlib.figure import Figure

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    model = limits.model
    for name, reach, gw, piw in zip(limits.end_effectors, limits.reachable, limits.guaranteed, limits.piw, strict=True):
        title = f"{model.name}: workspaces of {name}\nabout the system CM (1992 eqs. 15-17)"
        if model.is_planar:
            fig = Figure(figsize=(6.4, 6.0), layout="constrained")
            ax = fig.add_subplot()
            reach.plot(ax, color="C0", label=f"reachable [{reach.R_min:.3f}, {reach.R_max:.3f}] m")
            if gw.exists:
                gw.plot(ax, color="C2", label=f"guaranteed [{gw.R_min:.3f}, {gw.R_max:.3f}] m")
            if piw is not None:
                widest = "" if piw.R_min is None else f" (widest [{piw.R_min:.3f}, {piw.R_max:.3f}] m)"
                piw.plot(ax, color="C1", label=f"path-independent{widest}")
            ax.plot([0.0], [0.0], "k+", ms=10, mew=1.5, label="system CM")
            ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.1), ncols=2, fontsize="small", frameon=False)
            ax.set_title(title, fontsize="medium")
        else:
            fig = Figure(figsize=(12.0, 11.0), layout="constrained")
            cloud = workspace_cloud(model, name, samples=cloud_samples, criterion=limits.criterion)
            plot_workspace_sections(reach, gw, piw, cloud, fig=fig)
            fig.suptitle(title.replace("\n", " "))
        path = out / f"workspace_{_slug(model.name)}_{_slug(name)}.png"
        fig.savefig(path, dpi=dpi, bbox_inches="tight", pad_inches=0.15)
        written.append(path)
    return written


def limits_json(limits: WorkspaceLimits) -> str:
    """``limits.as_dict()`` as JSON text (NaN-free)."""
    import json

    def clean(value: Any) -> Any:
        if isinstance(value, dict):
            return {k: clean(v) for k, v in value.items()}
        if isinstance(value, (list, tuple)):
            return [clean(v) for v in value]
        if isinstance(value, (float, np.floating)):
            return float(value) if np.isfinite(value) else None
        return value

    return json.dumps(clean(limits.as_dict()), indent=2, allow_nan=False)

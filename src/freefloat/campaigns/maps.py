"""Maps as campaigns: the singularity measure and the end-effector distance over 10^8+ configurations, chunk by chunk.

A campaign file with a ``[map]`` table (instead of ``scenario``) samples the joint box of a model (its joint
limits; a full turn where a joint has none) with ONE scrambled Sobol sequence of ``samples`` points; each run
is a chunk of ``chunk`` consecutive points of that sequence (``fast_forward``), so the chunks together are the
same points as one call would draw, and a chunk is stored, resumed and never computed twice like any run::

    [map]
    model = "papadopoulos1992"     # built-in name, or a model file (relative to the campaign file)
    end_effector = 0               # name or index (default 0): |r_E| is its distance from the system CM
    samples = 134217728            # configurations in all (2^27; at most 2^30)
    chunk = 1048576                # configurations per run: a power of two
    seed = 0                       # of the scrambling
    bins = 128                     # histogram bins of |r_E| and of log10 |measure|
    [map.singularity]              # optional: as a capture scenario's [singularity] (rows, measure, threshold)

Each chunk records, with the batched :func:`freefloat.workspace.end_effector_radius` and
:meth:`~freefloat.workspace.SingularityCriterion.evaluate` (no second algorithm): the scalars
``configurations``, ``radius_min``, ``radius_max`` (m, about the system CM: attitude-free), ``measure_abs_min``,
``singular`` (configurations with |measure| <= threshold, or, with threshold 0, the smallest 1e-6 of the
measure's range), ``singular_radius_min`` / ``_max``; and the arrays ``radius_histogram`` (bins,),
``singular_radius_histogram`` (bins,) and ``map`` (bins x bins: |r_E| against log10 |measure|). The radius
bins span [0, :func:`radius_bound`]; the measure bins span ``MEASURE_DECADES``. Summed over the chunks
(:func:`freefloat.campaigns.report.map_totals`) they are the map of the whole sample.
"""

from __future__ import annotations

import functools
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from ..analysis._workspace_reach import end_effector_radius
from ..analysis.singularity import MEASURES, ROWS, SingularityCriterion
from ..core.barycentric import barycentric_vectors
from ..core.errors import ModelError
from ..core.model import Model
from ..models import load_model
from ..scenarios.scenario import _number, _table, _where
from ._fields import MAX_RUNS, integer_field

__all__ = ["MAP_SCALARS", "MAP_SERIES", "MEASURE_DECADES", "map_chunk", "map_from_dict", "map_runs", "radius_bound"]

#: What a map chunk records.
MAP_SCALARS = ("configurations", "radius_min", "radius_max", "measure_abs_min", "singular", "singular_radius_min", "singular_radius_max")
MAP_SERIES = ("radius_histogram", "singular_radius_histogram", "map")
#: The most configurations a map samples: the length of scipy's Sobol sequence (2^30, 1.07e9), the one of
#: :func:`freefloat.workspace.workspace_cloud` and the workspace searches (same seed, same points).
MAX_SAMPLES = 1 << 30
#: The span of the log10 |measure| bins (decades); values outside are counted in the end bins.
MEASURE_DECADES = (-8.0, 4.0)
_MAP_KEYS = {"model", "end_effector", "samples", "chunk", "seed", "bins", "singularity"}
_SINGULARITY_KEYS = {"rows", "measure", "threshold"}


def map_from_dict(data: Any, source: str, base: Path | None = None) -> dict[str, Any]:
    """The validated ``[map]`` table (plain values: it is hashed into the campaign's id and sent to the workers);
    ``base``: the folder of a relative model file. The samples, the chunks and a chunk's memory are checked here."""
    table = _table(data, _MAP_KEYS, source, "map")
    if not isinstance(table.get("model"), str):
        raise ModelError(
            _where(source, "map.model"), f"missing or not a string ({table.get('model')!r})", "give a built-in name or a model file"
        )
    ee = table.get("end_effector", 0)
    if isinstance(ee, bool) or not isinstance(ee, (int, str)):
        raise ModelError(_where(source, "map.end_effector"), f"expected a name or an index, got {ee!r}", "e.g. end_effector = 0")
    chunk = integer_field(table, "chunk", 1 << 20, 16, source, "map", "give a power of two, e.g. chunk = 1048576")
    if chunk & (chunk - 1):
        raise ModelError(
            _where(source, "map.chunk"), f"{chunk} is not a power of two", "give a power of two (Sobol points come in powers of two)"
        )
    samples = integer_field(table, "samples", chunk, chunk, source, "map", "give the configurations in all, a multiple of chunk")
    if samples > MAX_SAMPLES:
        raise ModelError(
            _where(source, "map.samples"),
            f"{samples:,} configurations are above the 2^30 ({MAX_SAMPLES:,}) of one Sobol sequence",
            "give samples <= 1073741824 (or map with another seed in a second campaign)",
        )
    if samples % chunk:
        raise ModelError(
            _where(source, "map.samples"), f"{samples} is not a multiple of chunk ({chunk})", "round samples to a multiple of chunk"
        )
    if samples // chunk > MAX_RUNS:
        raise ModelError(
            _where(source, "map.chunk"),
            f"{samples // chunk:,} chunks are above the {MAX_RUNS:,} runs a campaign can plan",
            "give a larger chunk",
        )
    singular = _table(table.get("singularity", {}), _SINGULARITY_KEYS, source, "map.singularity")
    for key, allowed in (("rows", ROWS), ("measure", MEASURES)):
        if key in singular and singular[key] not in allowed:
            raise ModelError(
                _where(source, f"map.singularity.{key}"), f"unknown value {singular[key]!r}", f"use one of {', '.join(allowed)}"
            )
    _check_chunk_memory(table["model"], base, chunk, source)
    threshold = _number(singular.get("threshold", 0.0), source, "map.singularity.threshold", "give a threshold >= 0")
    if threshold < 0.0:
        raise ModelError(_where(source, "map.singularity.threshold"), f"must be >= 0, got {threshold!r}", "give a threshold >= 0")
    return {
        "model": table["model"],
        "end_effector": ee,
        "samples": samples,
        "chunk": chunk,
        "seed": integer_field(table, "seed", 0, 0, source, "map", "e.g. seed = 0"),
        "bins": integer_field(table, "bins", 128, 2, source, "map", "e.g. bins = 128"),
        "rows": singular.get("rows", "auto"),
        "measure": singular.get("measure", "auto"),
        "threshold": threshold,
    }


def _check_chunk_memory(name: str, base: Path | None, chunk: int, source: str) -> None:
    """A chunk's arrays on a worker (the points, the radius and the measure's Jacobians: about 8 x (7 + 6) x N bytes per
    point for N joints) against this machine's free memory (:func:`freefloat.core.resources.require_memory`)."""
    from ..core.errors import MemoryBudgetError
    from ..core.resources import require_memory

    try:
        model = _model(name, str(base if base is not None else Path(".")))
    except (ModelError, OSError, KeyError, ValueError):
        return  # (the model's own error comes with the first chunk, named by load_model)
    try:
        require_memory(8.0 * (7 + 6) * len(model.joint_names) * chunk, f"a chunk of {chunk:,} configurations", "give a smaller chunk")
    except MemoryBudgetError as exc:
        raise ModelError(_where(source, "map.chunk"), str(exc), "give a smaller chunk (a power of two)") from None


def map_runs(table: dict[str, Any]) -> list[dict[str, Any]]:
    """The chunks of a map: ``{"start": first point, "size": points}`` in order."""
    return [{"start": start, "size": table["chunk"]} for start in range(0, table["samples"], table["chunk"])]


@functools.lru_cache(maxsize=4)
def _model(name: str, base: str) -> Model:
    """The map's model, read once per worker process."""
    path = Path(base) / name
    return load_model(str(path) if path.is_file() else name)


def radius_bound(model: Model) -> float:
    """An upper bound on |r_E| about the system CM over every configuration (m): the sum of the barycentric
    vectors' lengths (1992 eqs. 5-9), each body's |l*| + |r*| and |c*| (a triangle inequality)."""
    bary = barycentric_vectors(model)
    total = sum(float(np.linalg.norm(v)) for name in ("l_star", "r_star", "c_star") for v in np.reshape(getattr(bary, name), (-1, 3)))
    return 1.0001 * total


def map_chunk(table: dict[str, Any], base: str, start: int, size: int) -> tuple[dict[str, float], dict[str, np.ndarray]]:
    """One chunk of a map: its scalars and arrays (module docstring)."""
    from scipy.stats import qmc  # (imported here: not with freefloat)

    from ..analysis._workspace_search import model_box

    model = _model(table["model"], base)
    e = model.end_effector_index(table["end_effector"])
    box = model_box(model)
    sobol = qmc.Sobol(box.lo.size, scramble=True, seed=np.random.default_rng(table["seed"]))
    if start:  # (scipy's fast_forward(0) overflows)
        sobol.fast_forward(start)
    with warnings.catch_warnings():  # a chunk of a power-of-two sequence: the whole sample keeps the balance
        warnings.filterwarnings("ignore", "The balance properties of Sobol", UserWarning)
        q = box.lo + sobol.random(size) * (box.hi - box.lo)
    criterion = SingularityCriterion(rows=table["rows"], measure=table["measure"], threshold=table["threshold"])
    radius = end_effector_radius(model, q, e)
    measure = np.abs(criterion.evaluate(model, q, e))
    threshold = table["threshold"] if table["threshold"] > 0 else 1e-6 * float(np.max(measure, initial=0.0))
    singular = measure <= threshold
    bins, top = table["bins"], radius_bound(model)
    log_measure = np.log10(np.maximum(measure, 1e-300))
    span = (np.clip(radius, 0.0, top), np.clip(log_measure, *MEASURE_DECADES))
    grid, _, _ = np.histogram2d(*span, bins=bins, range=[(0.0, top), MEASURE_DECADES])
    hist = np.histogram(span[0], bins=bins, range=(0.0, top))[0]
    hist_singular = np.histogram(span[0][singular], bins=bins, range=(0.0, top))[0]
    some = bool(np.any(singular))
    scalars = {
        "configurations": float(size),
        "radius_min": float(radius.min()),
        "radius_max": float(radius.max()),
        "measure_abs_min": float(measure.min()),
        "singular": float(np.count_nonzero(singular)),
        "singular_radius_min": float(radius[singular].min()) if some else float("nan"),
        "singular_radius_max": float(radius[singular].max()) if some else float("nan"),
    }
    arrays = {
        "radius_histogram": hist.astype(np.int64),
        "singular_radius_histogram": hist_singular.astype(np.int64),
        "map": grid.astype(np.int64),
    }
    return scalars, arrays

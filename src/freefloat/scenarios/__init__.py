"""Scenario files (``ff.scenarios``): simulation scenarios and §V capture scenarios, read from TOML and run.

- :mod:`.scenario`: a simulation scenario (:class:`Scenario`, :func:`load_scenario`, :func:`run_scenario`);
  :mod:`.scenario_outputs` writes what ``freefloat simulate`` writes.
- :mod:`.capture_scenario`: a payload-capture scenario (:class:`CaptureScenario`,
  :func:`load_capture_scenario`, :func:`run_capture_scenario`), what ``freefloat capture`` runs.

A scenario's ``model`` is a built-in name or a model file, read by :func:`freefloat.models.load_model`.
Layer: imports everything below it (core, mechanics, simulation, control, analysis, io, models).
"""

from __future__ import annotations

from .capture_scenario import (
    CaptureResult,
    CaptureScenario,
    capture_scenario_from_dict,
    load_capture_scenario,
    run_capture_scenario,
    write_capture_outputs,
)
from .scenario import Scenario, load_scenario, run_scenario, scenario_from_dict
from .scenario_outputs import simulate_scenario, write_trajectory_outputs

__all__ = [
    "CaptureResult",
    "CaptureScenario",
    "Scenario",
    "capture_scenario_from_dict",
    "load_capture_scenario",
    "load_scenario",
    "run_capture_scenario",
    "run_scenario",
    "scenario_from_dict",
    "simulate_scenario",
    "write_capture_outputs",
    "write_trajectory_outputs",
]

"""Bad-input cases of issue 40: the capture sequence keys, targets, impact, detumbling, wheels (gathered by tests/test_bad_inputs.py).

The scenario cases edit ``examples/scenarios/tumbling_satellite_capture.toml`` (a capture sequence: [detumble] and
[[wheels]]) one key at a time, as ``CAPTURE_EDITS`` of tests/test_bad_inputs.py does for the older keys: every
[detumble] key and ``[grasp] time`` given text, a boolean, NaN, infinity, a negative and a huge value. Each is
refused when the scenario is read or when its run is estimated, before the plan.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

import freefloat as ff
from bad_case import Case, add_file, api, cli
from freefloat.core.errors import MemoryBudgetError, ModelError

ROOT = Path(__file__).resolve().parents[1]
TUMBLING = (ROOT / "examples" / "scenarios" / "tumbling_satellite_capture.toml").read_text()
MOVING = (ROOT / "examples" / "scenarios" / "papadopoulos1992_capture_moving.toml").read_text()
_GRASP = 'rank_by = "spacecraft_rate"             # the capture posture that leaves the spacecraft turning slowest'
_TIME = "time = 0.0   "


def _edit(text: str, old: str, new: str) -> str:
    if text.count(old) != 1:
        raise ValueError(f"{old!r} is not once in the file the case edits")
    return text.replace(old, new)


#: [detumble] numbers: (key, its line in the example, the huge value's message).
_NUMBERS = [
    (
        "rate_gain",
        "rate_gain = 0.5",
        r"detumble\.rate_gain: 1e\+300 1/s x sample_period 0\.05 s = 5e\+298: each sample would remove all",
    ),
    ("duration", "duration = 30.0", r"the capture sequence .*would need about .* of memory"),
    ("sample_period", "sample_period = 0.05", r"detumble\.sample_period: 1e\+300 s exceeds the duration"),
    ("specific_impulse", "specific_impulse = 220.0", r"detumble\.specific_impulse: 1e\+300 s is beyond 100000 s"),
    ("rest_rate", "rest_rate = 1e-3", r"detumble\.rest_rate: 1e\+300 rad/s is beyond 10000 rad/s"),
    ("rest_joint_rate", "rest_joint_rate = 1e-3", r"detumble\.rest_joint_rate: 1e\+300 rad/s is beyond 10000 rad/s"),
    ("rest_velocity", "rest_velocity = 1e-3", r"detumble\.rest_velocity: 1e\+300 m/s is beyond 1e\+08 m/s"),
]

#: (id, the edit of the example, the message).
EDITS: list[tuple[str, tuple[str, str], str]] = []
for _key, _line, _huge in _NUMBERS:
    EDITS += [
        (f"{_key}-text", (_line, f'{_key} = "0.5"'), rf"detumble\.{_key}: expected a number, got '0\.5'"),
        (f"{_key}-bool", (_line, f"{_key} = true"), rf"detumble\.{_key}: expected a number, got True"),
        (f"{_key}-nan", (_line, f"{_key} = nan"), rf"detumble\.{_key}: must be finite, got nan"),
        (f"{_key}-inf", (_line, f"{_key} = inf"), rf"detumble\.{_key}: must be finite, got inf"),
        (f"{_key}-negative", (_line, f"{_key} = -1.0"), rf"detumble\.{_key}: must be positive, got -1\.0"),
        (f"{_key}-huge", (_line, f"{_key} = 1e300"), _huge),
    ]
_FRAMES = "frames = 20"
EDITS += [
    # the runs: a year-long detumbling, a nanosecond sample period, a day-long one that fits in memory
    ("duration-1e9", ("duration = 30.0", "duration = 1e9"), r"the capture sequence .*would need about .* of memory"),
    ("sample-period-1e-9", ("sample_period = 0.05", "sample_period = 1e-9"), r"the capture sequence .*would need about .* of memory"),
    ("duration-long", ("duration = 30.0", "duration = 1e5"), r"the capture sequence is estimated to take over 60 s .*pass --yes"),
    ("rate-gain-too-fast", ("rate_gain = 0.5", "rate_gain = 40.0"), r"detumble\.rate_gain: 40 1/s x sample_period 0\.05 s = 2"),
    ("frames-text", (_FRAMES, 'frames = "20"'), r"detumble\.frames: expected an integer from 2 to 10000, got '20'"),
    ("frames-bool", (_FRAMES, "frames = true"), r"detumble\.frames: expected an integer from 2 to 10000, got True"),
    ("frames-float", (_FRAMES, "frames = 20.5"), r"detumble\.frames: expected an integer from 2 to 10000, got 20\.5"),
    ("frames-nan", (_FRAMES, "frames = nan"), r"detumble\.frames: expected an integer from 2 to 10000, got nan"),
    ("frames-negative", (_FRAMES, "frames = -20"), r"detumble\.frames: expected an integer from 2 to 10000, got -20"),
    ("frames-huge", (_FRAMES, "frames = 1000000000"), r"detumble\.frames: expected an integer from 2 to 10000, got 1000000000"),
    ("force-text", (_FRAMES, _FRAMES + '\nforce = "true"'), r"detumble\.force: expected true or false, got 'true'"),
    ("force-number", (_FRAMES, _FRAMES + "\nforce = 1"), r"detumble\.force: expected true or false, got 1"),
    ("torque-by-number", ('torque_by = "wheels"  ', "torque_by = 5  "), r"detumble\.torque_by: unknown 5"),
    ("torque-by-bool", ('torque_by = "wheels"  ', "torque_by = true  "), r"detumble\.torque_by: unknown True"),
    ("attitude-nan", (_FRAMES, _FRAMES + "\nattitude = [0.0, 0.0, nan, 1.0]"), r"detumble\.attitude: must be finite, got nan"),
    ("attitude-inf", (_FRAMES, _FRAMES + "\nattitude = [0.0, 0.0, inf, 1.0]"), r"detumble\.attitude: must be finite, got inf"),
    ("attitude-text", (_FRAMES, _FRAMES + '\nattitude = "up"'), r"detumble\.attitude: expected \[x, y, z, w\], got 'up'"),
    ("attitude-bools", (_FRAMES, _FRAMES + "\nattitude = [true, false, false, false]"), r"detumble\.attitude: expected a number, got True"),
    ("attitude-huge", (_FRAMES, _FRAMES + "\nattitude = [1e300, 0.0, 0.0, 0.0]"), r"detumble\.attitude: has norm 1e\+300, not 1"),
    ("attitude-short", (_FRAMES, _FRAMES + "\nattitude = [0.0, 1.0]"), r"detumble\.attitude: expected \[x, y, z, w\], got \[0\.0, 1\.0\]"),
    # the grasp time of the sequence, [grasp] time
    ("grasp-time-text", (_TIME, 'time = "2"   '), r"grasp\.time: expected a number, got '2'"),
    ("grasp-time-bool", (_TIME, "time = true   "), r"grasp\.time: expected a number, got True"),
    ("grasp-time-nan", (_TIME, "time = nan   "), r"grasp\.time: must be finite, got nan"),
    ("grasp-time-inf", (_TIME, "time = inf   "), r"grasp\.time: must be finite, got inf"),
    ("grasp-time-negative", (_TIME, "time = -2.0   "), r"grasp\.time: must be >= 0, got -2\.0"),
    ("grasp-time-huge", (_TIME, "time = 1e12   "), r"the capture sequence .*would need about .* of memory"),
    ("grasp-time-list", (_TIME, "time = [2.0]   "), r"grasp\.time: expected a number, got \[2\.0\]"),
]

CASES: list[Case] = []
for _id, (_old, _new), _match in EDITS:
    add_file(f"cap40/{_id}.toml", _edit(TUMBLING, _old, _new))
    CASES.append(cli(f"cli-capture40-{_id}", f"capture {{files}}/cap40/{_id}.toml", _match))
_MOVING_GRASP = (
    'rank_by = "spacecraft_rate"           # "measure" (1992 §V), "spacecraft_rate", "impulse", "angular_impulse", "joint_impulse"'
)
_MOVING_MASS = "mass = 400.0                          # kg"
for _id, _offset in (("payload-offset-beyond-reach", "[3.0, 0.0, 0.0]"), ("payload-offset-beyond-reach-z", "[0.0, 0.0, -2.6]")):
    add_file(f"cap40/{_id}.toml", _edit(MOVING, _MOVING_MASS, _MOVING_MASS + f"\noffset = {_offset}"))
    CASES.append(  # the hand off the payload: refused when the scenario is read, before the plan (review of 85de392)
        cli(
            f"cli-capture40-{_id}",
            f"capture {{files}}/cap40/{_id}.toml",
            r"payload\.offset: puts the payload's CM .* m from the hand, beyond 10",
        )
    )
add_file("cap40/grasp-time-without-sequence.toml", _edit(MOVING, _MOVING_GRASP, _MOVING_GRASP + "\ntime = 2.0"))
CASES.append(
    cli(
        "cli-capture40-grasp-time-without-sequence",
        "capture {files}/cap40/grasp-time-without-sequence.toml",
        r"grasp\.time: is the grasp time of the capture sequence, and there is none; add a \[detumble\] table",
    )
)


# ---- the API: a target the hand is not on, Detumble's fields, a controller of another robot
def _one_arm() -> tuple[ff.Model, ff.State, np.ndarray]:
    model = ff.models.papadopoulos1992(arms=1)
    state = ff.State(q=[0.5, 1.0])
    return model, state, ff.end_effector_positions(model, state.q)[0]


def _far_target() -> tuple[ff.Model, ff.State, Any]:
    model, state, tip = _one_arm()
    return (
        model,
        state,
        ff.capture.Target(mass=200.0, inertia=20.0, position=tip + np.array([50.0, 0.0, 0.0]), angular_velocity=[0.0, 0.0, 0.05]),
    )


def _impact_far(files: Path) -> Any:
    model, state, target = _far_target()
    return ff.capture.impact(model, state, target)


def _capture_far(at: float) -> Any:
    def run(files: Path) -> Any:
        model, state, target = _far_target()
        return ff.simulate(model, state, 2.0, capture=ff.Capture(target, at=at), fixed_step=0.01)

    return run


def _other_controller(files: Path) -> Any:
    model, state, tip = _one_arm()
    target = ff.capture.Target(mass=200.0, inertia=20.0, position=tip, angular_velocity=[0.0, 0.0, 0.05])
    other = ff.control.Detumble(ff.models.papadopoulos1992(arms=2))
    return ff.simulate(model, state, 1.0, capture=ff.Capture(target, at=0.5, controller_after=other), fixed_step=0.01)


def _detumble(**kwargs: Any) -> Any:
    return lambda files: ff.control.Detumble("papadopoulos1992-one-arm", **kwargs)


def _cost(**kwargs: Any) -> Any:
    def run(files: Path) -> Any:
        model, state, _ = _one_arm()
        traj = ff.simulate(model, state, 0.02, fixed_step=0.01)
        return ff.control.detumble_cost(traj, **kwargs)

    return run


def _scenario(edit: tuple[str, str]) -> Any:
    def run(files: Path) -> Any:
        import tomllib

        from freefloat.scenarios import capture_scenario_from_dict, run_capture_scenario

        data = tomllib.loads(_edit(TUMBLING, *edit))
        return run_capture_scenario(capture_scenario_from_dict(data, source="tumbling"))

    return run


_FAR = r"target: its CM at \[.*\] m is 50 m from the grasping end effector 'arm1_ee' at .* more than 10 of its radii of gyration"
CASES += [
    api("capture40-impact-target-50m", _impact_far, ValueError, _FAR),
    api("capture40-capture-at-0-target-50m", _capture_far(0.0), ValueError, r"^Capture\.at = 0 s: " + _FAR),
    api("capture40-capture-at-1-target-50m", _capture_far(1.0), ValueError, r"^Capture\.at = 1 s: target: its CM .* m from the grasping"),
    api(
        "capture40-controller-of-another-model",
        _other_controller,
        ValueError,
        r"Capture\.controller_after: was made for model 'papadopoulos1992' .*not for the simulated 'papadopoulos1992_one_arm'",
    ),
    api("capture40-detumble-rate-gain-text", _detumble(rate_gain="0.5"), TypeError, r"rate_gain: expected real numbers, got text"),
    api("capture40-detumble-rate-gain-nan", _detumble(rate_gain=float("nan")), ValueError, r"rate_gain: every gain must be positive"),
    api("capture40-detumble-force-text", _detumble(force="yes"), TypeError, r"force: expected True or False .*got str 'yes'"),
    api("capture40-detumble-force-number", _detumble(force=1), TypeError, r"force: expected True or False .*got int 1"),
    api("capture40-detumble-torque-by-number", _detumble(torque_by=5), ValueError, r"torque_by: expected one of 'thrusters', 'wheels'"),
    api(
        "capture40-detumble-attitude-text",
        _detumble(attitude="up"),
        TypeError,
        r"attitude: expected real numbers, got text",
    ),
    api(
        "capture40-detumble-attitude-gain-text",
        _detumble(attitude=[0.0, 0.0, 0.0, 1.0], attitude_gain="1"),
        TypeError,
        r"attitude_gain: expected a number \(1/s\^2\), got str '1'",
    ),
    api("capture40-cost-isp-text", _cost(specific_impulse="220"), TypeError, r"specific_impulse: expected a number \(s\), got str '220'"),
    api("capture40-cost-rest-rate-bool", _cost(rest_rate=True), TypeError, r"rest_rate: expected a number \(rad/s\), got bool True"),
    api("capture40-cost-rest-velocity-inf", _cost(rest_velocity=float("inf")), ValueError, r"rest_velocity: expected a positive finite"),
    api(
        "capture40-scenario-duration-1e9",
        _scenario(("duration = 30.0", "duration = 1e9")),
        MemoryBudgetError,
        r"the capture sequence .*would need about .* of memory",
    ),
    api(
        "capture40-scenario-grasp-time-text",
        _scenario((_TIME, 'time = "2"   ')),
        ModelError,
        r"tumbling: grasp\.time: expected a number, got '2'",
    ),
    api(
        "capture40-scenario-force-text",
        _scenario((_FRAMES, _FRAMES + '\nforce = "false"')),
        ModelError,
        r"detumble\.force: expected true or false, got 'false'",
    ),
]

"""Papadopoulos 1992 (large payload manipulation): the paper's printed numbers and freefloat's, row by row.

:func:`rows_1992` returns the report rows of DESIGN.md (``{id, paper, ours,
agrees, note}``) for Tables II-VI and the §V example. ``ours`` is always
computed from the built-in models (:func:`freefloat.models.papadopoulos1992`)
by :mod:`freefloat.workspace`, :mod:`freefloat.capture` and
:func:`freefloat.mechanics.planar.position_coefficients`. The printed numbers live
only in :data:`PRINTED`, as strings, so that their printed precision is
known. ``agrees`` is True when ``ours`` rounds to the printed value at the
printed precision.

Extra rows:

* ``<id>.collinear``: R_min read as the minimum over the "collinear"
  configurations q in {0, π}^N (:func:`freefloat.analysis.workspace.collinear_radius_range`),
  computed from our model.
* ``<id>.as_printed``: the same equation evaluated on the paper's own printed
  3-decimal coefficients (Tables II and IV, §V), with the collinear reading
  of eq. 15a for R_min; for §V, with the paper's printed R+ and q1. These
  reproduce every printed workspace number except PIW_min, q1 and θ.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..analysis.capture import CapturePlan, CapturePosture, capture_families, optimal_capture_posture, plan_capture
from ..analysis.workspace import (
    GuaranteedWorkspace,
    ReachableWorkspace,
    collinear_radii,
    collinear_radius_range,
    free_sum_radii,
    guaranteed_radii,
    guaranteed_workspace,
    path_independent_workspace,
    reachable_workspace,
)
from ..mechanics.planar import position_coefficients
from ..models import papadopoulos1992

__all__ = ["PAYLOAD_INERTIA", "PAYLOAD_MASS", "PRINTED", "Results1992", "agrees", "compute_1992", "rows_1992"]

#: The §IV-V payload: 400 kg, I_p = 25 kg m² about its CM, grasped at its CM by arm 1.
PAYLOAD_MASS = 400.0
PAYLOAD_INERTIA = 25.0
#: Length of the §V path AB, m.
PATH_LENGTH = 0.25
COEFFICIENTS = ("alpha", "beta", "gamma", "delta", "epsilon")
_ROMAN = {"T2": "II", "T4": "IV"}

#: Numbers as printed in the paper (strings keep the printed precision). None: "n/a".
PRINTED: dict[str, str | None] = {
    **{f"92.T2.arm1.{k}": v for k, v in zip(COEFFICIENTS, ("0.5", "0.907", "0.972", "-0.093", "-0.028"), strict=True)},
    **{f"92.T2.arm2.{k}": v for k, v in zip(COEFFICIENTS, ("-0.5", "-0.093", "-0.028", "0.907", "0.972"), strict=True)},
    **{
        f"92.T3.arm{m}.{k}": v for m in (1, 2) for k, v in (("R_max", "2.50"), ("R_min", "0.314"), ("GW_max", "1.258"), ("GW_min", "0.686"))
    },
    **{f"92.T4.arm1.{k}": v for k, v in zip(COEFFICIENTS, ("0.287", "0.522", "0.559", "-0.053", "-0.016"), strict=True)},
    **{f"92.T4.arm2.{k}": v for k, v in zip(COEFFICIENTS, ("-0.713", "-0.478", "-0.491", "0.947", "0.984"), strict=True)},
    **{"92.T5.arm1.R_max": "1.437", "92.T5.arm1.R_min": "0.181", "92.T5.arm1.GW_max": "0.725", "92.T5.arm1.GW_min": "0.393"},
    **{"92.T5.arm2.R_max": "3.613", "92.T5.arm2.R_min": "0.219", "92.T5.arm2.GW_max": None, "92.T5.arm2.GW_min": None},
    **{"92.S5.alpha": "0.230", "92.S5.beta": "0.483", "92.S5.gamma": "0.523"},
    **{
        "92.T6.R_max": "1.236",
        "92.T6.R_min": "0.190",
        "92.T6.PIW_max": "0.776",
        "92.T6.PIW_min": "0.370",
        "92.T6.GW_max": "0.776",
        "92.T6.GW_min": "0.270",
    },
    **{"92.S5.R_plus": "0.540", "92.S5.approach_distance": "1", "92.S5.q1_deg": "79", "92.S5.q2_deg": "97.97", "92.S5.theta_deg": "-109"},
}


def _printed(key: str) -> float | None:
    text = PRINTED[key]
    return None if text is None else float(text)


def agrees(key: str, ours: float | None) -> bool:
    """True when ``ours`` rounds to the printed value of ``key`` at its printed precision (both None: True)."""
    text = PRINTED[key.removesuffix(".as_printed").removesuffix(".collinear")]
    if text is None or ours is None:
        return text is None and ours is None
    decimals = len(text.split(".")[1]) if "." in text else 0
    return bool(abs(float(ours) - float(text)) <= 0.5 * 10.0**-decimals * (1.0 + 1e-9))


@dataclass(frozen=True, eq=False)
class Results1992:
    """Everything :func:`rows_1992` reports, computed from the models."""

    coefficients: dict[str, np.ndarray]  # "T2.arm1" ... -> real eq. 18 coefficients, spacecraft first
    reachable: dict[str, ReachableWorkspace]  # "T3.arm1", "T5.arm2", "T6"
    guaranteed: dict[str, GuaranteedWorkspace]
    collinear: dict[str, float]  # collinear R_min from the model
    plan: CapturePlan  # §V with our rule for R+
    posture_at_printed_R_plus: CapturePosture  # optimal posture for R+ = 0.540
    sensitivity_piw_min: float  # d PIW_min / d I_p, m per kg m²


def _coefficients(model: Any, e: int) -> np.ndarray:
    return np.real(position_coefficients(model, e))


def compute_1992(samples: int = 1 << 18) -> Results1992:
    """Compute the 1992 tables and the §V example with freefloat (a few seconds)."""
    two = papadopoulos1992(arms=2)
    two_p = two.with_payload(0, mass=PAYLOAD_MASS, inertia=PAYLOAD_INERTIA)
    one = papadopoulos1992(arms=1)
    one_p = one.with_payload(0, mass=PAYLOAD_MASS, inertia=PAYLOAD_INERTIA)
    systems = {"T3.arm1": (two, 0), "T3.arm2": (two, 1), "T5.arm1": (two_p, 0), "T5.arm2": (two_p, 1), "T6": (one_p, 0)}
    coefficients = {
        "T2.arm1": _coefficients(two, 0),
        "T2.arm2": _coefficients(two, 1),
        "T4.arm1": _coefficients(two_p, 0),
        "T4.arm2": _coefficients(two_p, 1),
        "S5": _coefficients(one_p, 0),
    }
    reachable = {k: reachable_workspace(m, e) for k, (m, e) in systems.items()}
    guaranteed = {k: guaranteed_workspace(m, e) for k, (m, e) in systems.items()}
    collinear = {k: collinear_radius_range(m, e).min for k, (m, e) in systems.items()}
    plan = plan_capture(one, 0, [[0.0, 0.0], [0.0, PATH_LENGTH]], samples=samples, mass=PAYLOAD_MASS, inertia=PAYLOAD_INERTIA)
    posture_printed = optimal_capture_posture(one_p, 0, float(PRINTED["92.S5.R_plus"] or 0.0))
    d_inertia = 1.0
    lo = path_independent_workspace(one.with_payload(0, mass=PAYLOAD_MASS, inertia=PAYLOAD_INERTIA - d_inertia), samples=1 << 16).R_min
    hi = path_independent_workspace(one.with_payload(0, mass=PAYLOAD_MASS, inertia=PAYLOAD_INERTIA + d_inertia), samples=1 << 16).R_min
    sensitivity = (float(hi or 0.0) - float(lo or 0.0)) / (2.0 * d_inertia)
    return Results1992(coefficients, reachable, guaranteed, collinear, plan, posture_printed, sensitivity)


def _printed_coefficients(table: str, arm: int) -> np.ndarray:
    return np.array([_printed(f"92.{table}.arm{arm}.{k}") for k in COEFFICIENTS], dtype=float)


def _printed_limits(coeffs: np.ndarray, own: list[int]) -> dict[str, float | None]:
    """Eqs. 15-16 on printed coefficients: R_max (polygon rule), collinear R_min, GW radii."""
    mask = np.zeros(coeffs.size, dtype=bool)
    mask[own] = True
    g = guaranteed_radii(free_sum_radii(coeffs[~mask]), free_sum_radii(coeffs[mask]))
    return {"R_max": free_sum_radii(coeffs).max, "R_min": collinear_radii(coeffs).min, "GW_max": g.R_max, "GW_min": g.R_min}


def _row(key: str, ours: float | None, note: str = "") -> dict[str, Any]:
    base = key.removesuffix(".as_printed").removesuffix(".collinear")
    return {"id": key, "paper": _printed(base), "ours": None if ours is None else float(ours), "agrees": agrees(key, ours), "note": note}


def rows_1992(results: Results1992 | None = None) -> list[dict[str, Any]]:
    """The 1992 report rows (DESIGN.md) with notes on every disagreement."""
    r = results if results is not None else compute_1992()
    rows: list[dict[str, Any]] = []
    c = r.coefficients
    m_total = {"T4": 940.0}
    b1 = 1.0 - c["T4.arm1"][1]
    notes_t4 = {
        "92.T4.arm1.beta": f"β⁽¹⁾ = r*_1 = 1 m - b_1, b_1 = (40·0.5 + 430·1.0)/{m_total['T4']:.0f} = {b1:.5f} m: "
        f"β⁽¹⁾ = {c['T4.arm1'][1]:.5f}. The printed pair 0.522 / -0.478 keeps β⁽¹⁾ - β⁽²⁾ = 1 m but is 0.0007 off: "
        "an arithmetic slip (b_1 = 0.478); Table V used it",
        "92.T4.arm2.beta": f"β⁽²⁾ = l*_1 = -b_1 = {c['T4.arm2'][1]:.5f} rounds to -0.479; see 92.T4.arm1.beta",
        "92.T4.arm2.gamma": f"γ⁽²⁾ = l*_2 = -b_2 = -(30·0.5 + 400·1.0)/940 = {c['T4.arm2'][2]:.5f}; "
        f"γ⁽¹⁾ - γ⁽²⁾ must be the 1.0 m link length (ours {c['T4.arm1'][2] - c['T4.arm2'][2]:.4f}; "
        "printed 0.559 + 0.491 = 1.050): -0.491 is a misprint, used in Table V (92.T5.arm2.*.as_printed)",
    }
    for table in ("T2", "T4"):
        for arm in (1, 2):
            for k, name in enumerate(COEFFICIENTS):
                key = f"92.{table}.arm{arm}.{name}"
                rows.append(_row(key, c[f"{table}.arm{arm}"][k], notes_t4.get(key, "")))
    for table, coeff_table in (("T3", "T2"), ("T5", "T4")):
        for arm in (1, 2):
            tag = f"{table}.arm{arm}"
            reach, gw = r.reachable[tag], r.guaranteed[tag]
            printed = _printed_limits(_printed_coefficients(coeff_table, arm), [1, 2] if arm == 1 else [3, 4])
            ours = {"R_max": reach.R_max, "R_min": reach.R_min, "GW_max": gw.R_max, "GW_min": gw.R_min}
            lengths = np.abs(c[f"{coeff_table}.arm{arm}"])
            for name in ("R_max", "R_min", "GW_max", "GW_min"):
                key = f"92.{tag}.{name}"
                note = _limit_note(key, name, reach, gw, lengths, coeff_table)
                rows.append(_row(key, ours[name], note))
                if name == "R_min":
                    rows.append(
                        _row(
                            key + ".collinear",
                            r.collinear[tag],
                            "min |r_E| over q in {0, π}^4 (links along or against their parents), our model",
                        )
                    )
                if not agrees(key, ours[name]):
                    rows.append(
                        _row(
                            key + ".as_printed",
                            printed[name],
                            f"eq. 15/16 on the paper's printed Table {_ROMAN[coeff_table]} coefficients"
                            + (" (collinear R_min)" if name == "R_min" else ""),
                        )
                    )
    for k, name in enumerate(("alpha", "beta", "gamma")):
        rows.append(_row(f"92.S5.{name}", c["S5"][k]))
    rows += _rows_t6(r)
    rows += _rows_s5(r)
    return rows


def _limit_note(key: str, name: str, reach: ReachableWorkspace, gw: GuaranteedWorkspace, lengths: np.ndarray, table: str) -> str:
    if name.startswith("GW") and not gw.exists:
        return f"n/a: {gw.reason}"
    header = "; the printed column header of GW_min (R'_max / R''_max) is a misprint for R'_min" if name == "GW_min" else ""
    if agrees(key, {"R_max": reach.R_max, "R_min": reach.R_min, "GW_max": gw.R_max, "GW_min": gw.R_min}[name]):
        return (reach.method if name.startswith("R") else gw.method) + header
    if name == "R_min":
        return (
            f"true minimum of eq. 15a: the vectors (|a| = {', '.join(f'{v:.4f}' for v in lengths)}) close a polygon "
            f"(longest {lengths.max():.4f} < the others' sum {lengths.sum() - lengths.max():.4f}), so |r_E| reaches 0. "
            "The printed value is the minimum over the collinear configurations (.collinear, .as_printed)"
        )
    if "T5.arm2" in key:
        return (
            f"computed with γ⁽²⁾ = {-lengths[2]:.4f}; the printed value uses the misprinted γ⁽²⁾ = -0.491 (92.T4.arm2.gamma, .as_printed)"
        )
    if "T5.arm1" in key:
        return f"from our coefficients; the printed value uses the printed β⁽¹⁾ = 0.522 (ours {lengths[1]:.5f}, 92.T4.arm1.beta){header}"
    return f"from our unrounded Table {_ROMAN[table]} coefficients; the paper used them rounded to 3 decimals (.as_printed){header}"


def _rows_t6(r: Results1992) -> list[dict[str, Any]]:
    reach, gw = r.reachable["T6"], r.guaranteed["T6"]
    piw = r.plan.piw
    lengths = np.abs(r.coefficients["S5"])
    printed = _printed_limits(np.array([_printed(f"92.S5.{k}") for k in ("alpha", "beta", "gamma")], dtype=float), [1, 2])
    inner = [iv for iv in piw.piw if iv != (piw.R_min, piw.R_max)]
    rows = [
        _row("92.T6.R_max", reach.R_max, reach.method),
        _row(
            "92.T6.R_min",
            reach.R_min,
            f"true minimum: {lengths[2]:.4f} < {lengths[0]:.4f} + {lengths[1]:.4f}, so |r_E| reaches 0; "
            "printed = collinear minimum (.collinear, .as_printed)",
        ),
        _row("92.T6.R_min.collinear", r.collinear["T6"], "min |r_E| over q in {0, π}^2, our model"),
        _row("92.T6.R_min.as_printed", printed["R_min"], "collinear minimum on the printed §V coefficients"),
        _row(
            "92.T6.PIW_max",
            piw.R_max,
            f"widest PIW interval; PDW {', '.join(f'[{a:.4f}, {b:.4f}]' for a, b in piw.pdw)} m"
            + (
                f"; the disk {', '.join(f'[{a:.4f}, {b:.4f}]' for a, b in inner)} m is singularity-free too (not in the paper)"
                if inner
                else ""
            ),
        ),
    ]
    p_min = piw.R_min
    note = (
        f"largest |r_E| on the inner branch of det J* = 0, polished by SLSQP (accuracy {piw.accuracy:.1e} m, "
        f"grid {piw.samples} configurations); PIW_min grows with I_p at {r.sensitivity_piw_min:.4f} m per kg m², "
        f"so 0.370 would need I_p ≈ {PAYLOAD_INERTIA + (0.370 - float(p_min or 0.0)) / r.sensitivity_piw_min:.1f} kg m²; "
        "no assumption we know reproduces it (not tuned): likely the resolution of the paper's search"
        if not agrees("92.T6.PIW_min", p_min)
        else "polished on the singular set"
    )
    rows.append(_row("92.T6.PIW_min", p_min, note))
    rows.append(_row("92.T6.GW_max", gw.R_max, gw.method))
    rows.append(
        _row("92.T6.GW_min", gw.R_min, f"{gw.method}; the disk |r| < {gw.inner_radius or 0.0:.4f} m is guaranteed too (eq. 16 omits it)")
    )
    return rows


def _rows_s5(r: Results1992) -> list[dict[str, Any]]:
    plan, placement, posture = r.plan, r.plan.placement, r.plan.posture
    m_robot = float(placement.robot_mass or 0.0)
    m_p = float(placement.payload_mass or 0.0)
    r_plus_printed = float(_printed("92.S5.R_plus") or 0.0)
    q1_printed = float(_printed("92.S5.q1_deg") or 0.0)
    r_in, r_out = placement.interval
    fam = capture_families(plan.captured, 0, r_plus_printed, np.radians(q1_printed))
    q2_at_79 = float(np.degrees(fam.q2[0]))
    det_at_79 = abs(float(fam.det[0]))
    best = r.posture_at_printed_R_plus
    q_paper = np.radians([q1_printed, q2_at_79])
    from ..mechanics.kinematics import end_effector_positions

    r0 = end_effector_positions(plan.captured, q_paper)[0]
    theta_at_paper = float(np.degrees(-np.arctan2(r0[1], r0[0])))
    theta_err = float(np.degrees(np.arctan2(r0[1], r0[0])) + float(_printed("92.S5.theta_deg") or 0.0))
    rows = [
        _row(
            "92.S5.R_plus",
            placement.R_plus,
            f"our rule: (CM+)A ⟂ AB and the path centred radially in the PIW [{r_in:.4f}, {r_out:.4f}] m: "
            f"R+ - r_in = r_out - sqrt(R+² + L²) (margin {placement.margin:.4f} m). "
            "The printed 0.540 is what a round approach distance R = 1 m gives (.as_printed)",
        ),
        _row(
            "92.S5.R_plus.as_printed",
            m_robot / (m_robot + m_p) * 1.0,
            "R+ = M / (M + m_p) · 1 m: eq. 19 solved for a round approach distance R = 1 m",
        ),
        _row(
            "92.S5.approach_distance",
            placement.approach_distance,
            f"eq. 19: (M + m_p)/M · R+ = ({m_robot:.0f} + {m_p:.0f})/{m_robot:.0f} · {placement.R_plus:.4f} m",
        ),
        _row(
            "92.S5.q1_deg",
            np.degrees(posture.q[0]),
            f"max |det J*| subject to |r_E| = R+ (SLSQP from both eq. 21 families). |det J*| is flat along the family: "
            f"at R+ = 0.540 its maximum {best.measure:.5f} is at q1 = {np.degrees(best.q[0]):.2f}°, and at the printed "
            f"q1 = 79° it is {det_at_79:.5f} ({100 * (1 - det_at_79 / best.measure):.1f} % lower). Not reproducible: the "
            "maximum stays near 91° for any payload inertia from 0 to 200 kg m² (docs/workspaces.md)",
        ),
        _row(
            "92.S5.q2_deg",
            np.degrees(posture.q[1]),
            f"at our optimum (R+ = {placement.R_plus:.4f} m); at R+ = 0.540 m it is {np.degrees(best.q[1]):.2f}°",
        ),
        _row("92.S5.q2_deg.as_printed", q2_at_79, "eq. 21 (family 1) at the printed R+ = 0.540 m and q1 = 79°"),
        _row(
            "92.S5.theta_deg",
            np.degrees(posture.theta or 0.0),
            f"eq. 20 with x_E = R+, y_E = 0 at our optimum; at the paper's own posture (R+ = 0.540, q1 = 79°, "
            f"q2 = {q2_at_79:.2f}°) eq. 20 gives θ = {theta_at_paper:.2f}°, so the printed -109° misses it by "
            f"{abs(theta_err):.1f}° (not reproducible)",
        ),
    ]
    return rows


TITLE = "Papadopoulos 1992, large payload manipulation by space robots: paper vs freefloat"
INTRO = """\
Written by `freefloat reproduce 1992`. `paper` is the number printed in the paper, `ours` freefloat's own
answer to the quantity as the paper defines it (computed from the built-in models
`ff.models.papadopoulos1992(arms=2|1)`, never typed in), `agrees` whether `ours` rounds to the printed
value at the printed precision. Extra rows: `.collinear` = R_min read as the minimum over q in {0, π}^N
(our model); `.as_printed` = the same equations on the paper's own printed 3-decimal coefficients (and,
for §V, its printed R+ and q1), which reproduce the printed numbers where the paper's arithmetic differs.

In short: every Table II coefficient agrees; Table IV has an arithmetic slip (β⁽¹⁾ = 0.522, ours 0.52128)
and a misprint (γ⁽²⁾ = -0.491, ours -0.44149; γ⁽¹⁾ - γ⁽²⁾ must be the 1 m link length), which Table V
inherits; the printed R_min values are minima over collinear configurations (with free joints the true
minimum of eq. 15a is 0); Tables III/V used rounded coefficients; Table VI agrees except PIW_min (0.3689
vs 0.370, not reproducible by any assumption we know); in §V the paper's R+ = 0.540 is what a round
approach distance R = 1 m gives, |det J*| is flat along the eq. 21 family (ours 90.5°, the paper 79°),
and the printed θ = -109° is not consistent with eq. 20 at the paper's own posture. Each row's note
gives the evidence; docs/workspaces.md discusses them."""

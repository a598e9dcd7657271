"""Papadopoulos 1992, the workspace tables (III, V, VI) and the §V capture example, paper vs freefloat.

Each test prints its rows (id, paper, ours, agrees at the printed precision)
from :func:`freefloat.papers.paper1992.rows_1992` and asserts which ones agree. Every
disagreement is asserted against an independent computation (plain recursive
forward kinematics, brute force, scipy root finding) with its explanation in a
comment; nothing is tuned to the printed numbers. In short:

* R_min: the paper's values are the minimum over "collinear" configurations
  q in {0, π}^N; with free joints the true minimum of eq. 15a is 0.
* Tables III/V: the paper evaluated eqs. 15-16 on its 3-decimal coefficients
  (Table II rounded; Table IV with the slip β⁽¹⁾ = 0.522 and the misprint
  γ⁽²⁾ = -0.491), which the ``.as_printed`` rows reproduce exactly.
* Table VI: PIW_min 0.3689 vs 0.370 (not reproducible); the rest agrees.
* §V: R+ 0.5451 by our rule (0.540 = a round R = 1 m), q1 91° vs 79° on a
  flat maximum, θ not consistent with the paper's own posture.
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
import pytest
from scipy.optimize import brentq, least_squares, minimize_scalar

import freefloat as ff
from freefloat.analysis.capture import capture_families
from freefloat.papers.paper1992 import Results1992, compute_1992, rows_1992

TWO = ff.models.papadopoulos1992(arms=2)
TWO_P = TWO.with_payload(0, mass=400.0, inertia=25.0)
ONE_P = ff.models.papadopoulos1992(arms=1).with_payload(0, mass=400.0, inertia=25.0)


@pytest.fixture(scope="module")
def results() -> Results1992:
    return compute_1992()


@pytest.fixture(scope="module")
def rows(results: Results1992) -> dict[str, dict[str, Any]]:
    return {row["id"]: row for row in rows_1992(results)}


def show(rows: dict[str, dict[str, Any]], prefix: str) -> dict[str, dict[str, Any]]:
    picked = {k: v for k, v in rows.items() if k.startswith(prefix)}
    print(f"\n{'id':34s} {'paper':>8s} {'ours':>10s}  agrees")
    for k, v in picked.items():
        ours = "None" if v["ours"] is None else f"{v['ours']:.5f}"
        print(f"{k:34s} {v['paper']!s:>8s} {ours:>10s}  {v['agrees']}")
    return picked


def check_agreement(picked: dict[str, dict[str, Any]], disagree: set[str]) -> None:
    assert set(disagree) <= set(picked)
    for key, row in picked.items():
        assert row["agrees"] is (key not in disagree), key


# ----------------------------------------------------------------------------------------------------------------- independent tools
def radius_fk(model: ff.Model, q: Any, e: int) -> np.ndarray:
    """|r_E| by plain recursive forward kinematics (not the barycentric sums)."""
    return np.linalg.norm(ff.end_effector_positions(model, np.asarray(q, dtype=float), method="recursive")[..., e, :], axis=-1)


def collinear_min_fk(model: ff.Model, e: int) -> float:
    q = np.array(list(itertools.product((0.0, np.pi), repeat=model.n_joints)))
    return float(radius_fk(model, q, e).min())


def zero_radius(model: ff.Model, e: int) -> float:
    """The smallest |r_E| least squares finds from a few starts (0 when the vectors close a polygon)."""
    best = np.inf
    for start in np.random.default_rng(0).uniform(-np.pi, np.pi, size=(8, model.n_joints)):
        res = least_squares(lambda q: ff.end_effector_positions(model, q, method="recursive")[e], start, xtol=1e-15, ftol=1e-15, gtol=1e-15)
        best = min(best, float(np.linalg.norm(res.fun)))
    return best


def gw_by_fk(model: ff.Model, e: int, own: list[int], n: int = 16) -> tuple[float, float]:
    """Eq. 16 from forward kinematics only. With the own joints turning full circles, the own-arm term averages
    to zero, so the centre it circles is c = mean of r_E over the own joints; |c| over the other joints gives the
    first term, |r_E - c| over the own joints the second. The grid mean is exact (the terms are first harmonics)
    and, n being even, the grid holds the collinear configurations where these systems reach their extremes."""
    other = [j for j in range(model.n_joints) if j not in own]
    angles = np.linspace(-np.pi, np.pi, n, endpoint=False)
    own_grid = np.array(list(itertools.product(angles, repeat=len(own))))
    other_grid = np.array(list(itertools.product(angles, repeat=len(other)))) if other else np.zeros((1, 0))
    q = np.zeros((other_grid.shape[0], own_grid.shape[0], model.n_joints))
    q[..., own] = own_grid[None]
    q[..., other] = other_grid[:, None]
    r_e = ff.end_effector_positions(model, q, method="recursive")[..., e, :]
    c = r_e.mean(axis=1, keepdims=True)
    c_max = float(np.linalg.norm(c, axis=-1).max())
    own_r = np.linalg.norm(r_e - c, axis=-1)
    return c_max + float(own_r.min()), float(own_r.max()) - c_max  # (R'_min, R'_max)


def brute_max(model: ff.Model, e: int) -> float:
    q = np.random.default_rng(1).uniform(-np.pi, np.pi, size=(1 << 18, model.n_joints))
    return float(radius_fk(model, q, e).max())


# ----------------------------------------------------------------------------------------------------------------- Table III
def test_table3_workspaces_without_payload(rows: dict[str, dict[str, Any]]) -> None:
    picked = show(rows, "92.T3.")
    # Disagreements (each explained and checked below):
    #  R_min: true minimum 0 (polygon closes); paper = collinear minimum 0.3148 ... printed 0.314 (rounded coefficients)
    #  R_min.collinear: 0.31481 from our exact coefficients rounds to 0.315, the paper's 3-decimal Table II gives 0.314
    #  GW_max 1.25926 / GW_min 0.68519: the paper's 1.258 / 0.686 come from the 3-decimal Table II (as_printed agrees)
    disagree = {f"92.T3.arm{m}.{k}" for m in (1, 2) for k in ("R_min", "R_min.collinear", "GW_max", "GW_min")}
    check_agreement(picked, disagree)
    for m in (1, 2):
        e = m - 1
        own = [0, 1] if m == 1 else [2, 3]
        assert picked[f"92.T3.arm{m}.R_max"]["ours"] == pytest.approx(
            radius_fk(TWO, [0.0, 0.0, np.pi, 0.0], e)  # every term aligned (arm 2 folded back for arm 1 and vice versa)
        )
        assert brute_max(TWO, e) <= picked[f"92.T3.arm{m}.R_max"]["ours"] + 1e-12
        assert picked[f"92.T3.arm{m}.R_min"]["ours"] == pytest.approx(0.0, abs=1e-12)
        assert zero_radius(TWO, e) < 1e-12  # |r_E| = 0 is reached: the paper's 0.314 is not min over all q
        assert picked[f"92.T3.arm{m}.R_min.collinear"]["ours"] == pytest.approx(collinear_min_fk(TWO, e), abs=1e-12)
        assert picked[f"92.T3.arm{m}.R_min.as_printed"]["ours"] == pytest.approx(0.5 + 0.907 - 0.972 - 0.093 - 0.028, abs=1e-12)
        gw_min, gw_max = gw_by_fk(TWO, e, own)
        assert picked[f"92.T3.arm{m}.GW_max"]["ours"] == pytest.approx(gw_max, abs=1e-9)
        assert picked[f"92.T3.arm{m}.GW_min"]["ours"] == pytest.approx(gw_min, abs=1e-9)
        assert picked[f"92.T3.arm{m}.GW_max.as_printed"]["ours"] == pytest.approx((0.907 + 0.972) - (0.5 + 0.093 + 0.028), abs=1e-12)
        assert picked[f"92.T3.arm{m}.GW_min.as_printed"]["ours"] == pytest.approx((0.5 + 0.093 + 0.028) + (0.972 - 0.907), abs=1e-12)


# ----------------------------------------------------------------------------------------------------------------- Table V
def test_table5_workspaces_with_payload(rows: dict[str, dict[str, Any]]) -> None:
    picked = show(rows, "92.T5.")
    # Arm 1: R_max 1.43617, GW 0.72340 / 0.39362 differ from 1.437, 0.725, 0.393 because the paper used its printed
    # β⁽¹⁾ = 0.522 (ours 0.52128, a slip in Table IV); R_min as in Table III (collinear: 0.18085 agrees).
    # Arm 2: R_max 3.56383 vs 3.613 and collinear R_min 0.17021 vs 0.219: the paper used the misprinted
    # γ⁽²⁾ = -0.491 (ours -0.44149; γ⁽¹⁾ - γ⁽²⁾ must be the 1 m link length). GW n/a in both.
    disagree = {"92.T5.arm1.R_max", "92.T5.arm1.R_min", "92.T5.arm1.GW_max", "92.T5.arm1.GW_min"}
    disagree |= {"92.T5.arm2.R_max", "92.T5.arm2.R_min", "92.T5.arm2.R_min.collinear"}
    check_agreement(picked, disagree)
    a1 = np.real(ff.planar.position_coefficients(TWO_P, 0))
    a2 = np.real(ff.planar.position_coefficients(TWO_P, 1))
    assert a1[2] - a2[2] == pytest.approx(1.0, abs=1e-12)  # γ⁽¹⁾ - γ⁽²⁾ = link length; printed: 0.559 + 0.491 = 1.050
    assert a1[1] - a2[1] == pytest.approx(1.0, abs=1e-12)  # β⁽¹⁾ - β⁽²⁾ = link length (printed 0.522 + 0.478 = 1.000)
    for m, a in ((1, a1), (2, a2)):
        e = m - 1
        assert picked[f"92.T5.arm{m}.R_max"]["ours"] == pytest.approx(np.sum(np.abs(a)), abs=1e-12)
        assert brute_max(TWO_P, e) <= picked[f"92.T5.arm{m}.R_max"]["ours"] + 1e-12
        assert zero_radius(TWO_P, e) < 1e-12
        assert picked[f"92.T5.arm{m}.R_min.collinear"]["ours"] == pytest.approx(collinear_min_fk(TWO_P, e), abs=1e-12)
    gw_min, gw_max = gw_by_fk(TWO_P, 0, [0, 1])
    assert picked["92.T5.arm1.GW_max"]["ours"] == pytest.approx(gw_max, abs=1e-9)
    assert picked["92.T5.arm1.GW_min"]["ours"] == pytest.approx(gw_min, abs=1e-9)
    gw_min, gw_max = gw_by_fk(TWO_P, 1, [2, 3])
    assert gw_max < gw_min  # no guaranteed workspace for arm 2: "n/a" in the paper, None in ours
    assert picked["92.T5.arm2.GW_max"]["ours"] is None and picked["92.T5.arm2.GW_min"]["ours"] is None
    # .as_printed: the same equations on the printed Table IV
    assert picked["92.T5.arm1.R_max.as_printed"]["ours"] == pytest.approx(0.287 + 0.522 + 0.559 + 0.053 + 0.016, abs=1e-12)
    assert picked["92.T5.arm1.GW_max.as_printed"]["ours"] == pytest.approx((0.522 + 0.559) - (0.287 + 0.053 + 0.016), abs=1e-12)
    assert picked["92.T5.arm1.GW_min.as_printed"]["ours"] == pytest.approx((0.287 + 0.053 + 0.016) + (0.559 - 0.522), abs=1e-12)
    assert picked["92.T5.arm2.R_max.as_printed"]["ours"] == pytest.approx(0.713 + 0.478 + 0.491 + 0.947 + 0.984, abs=1e-12)
    printed = [-0.713, -0.478, -0.491, 0.947, 0.984]
    signed = [
        abs(printed[0] + sum(s * a for s, a in zip(signs, printed[1:], strict=True))) for signs in itertools.product((1, -1), repeat=4)
    ]
    assert picked["92.T5.arm2.R_min.as_printed"]["ours"] == pytest.approx(min(signed), abs=1e-12)
    assert min(signed) == pytest.approx(abs(-0.713 + 0.478 + 0.491 + 0.947 - 0.984), abs=1e-12)  # = 0.219


# ----------------------------------------------------------------------------------------------------------------- Table VI
def test_table6_workspaces_after_capture(rows: dict[str, dict[str, Any]]) -> None:
    picked = show(rows, "92.T6.")
    # R_min: 0 (0.523 < 0.230 + 0.483), paper = collinear 0.18966 (agrees). PIW_min: ours 0.36886 vs printed 0.370,
    # checked below by an independent root-finding along the singular curve; not reproducible by any assumption we
    # know (it is sensitive to I_p, see the row note); every other Table VI number agrees.
    check_agreement(picked, {"92.T6.R_min", "92.T6.PIW_min"})
    alpha, beta, gamma = np.real(ff.planar.position_coefficients(ONE_P, 0))
    assert picked["92.T6.R_max"]["ours"] == pytest.approx(alpha + beta + gamma, abs=1e-12)
    assert zero_radius(ONE_P, 0) < 1e-12
    assert picked["92.T6.R_min.collinear"]["ours"] == pytest.approx(collinear_min_fk(ONE_P, 0), abs=1e-12)
    gw_min, gw_max = gw_by_fk(ONE_P, 0, [0, 1], n=360)
    assert picked["92.T6.GW_max"]["ours"] == pytest.approx(gw_max, abs=1e-9)
    assert picked["92.T6.GW_min"]["ours"] == pytest.approx(gw_min, abs=1e-9)
    # PIW, independently: for each q1 the roots q2 of det J*(q1, q2) (brentq), then the radius along the branches.
    det = lambda q1, q2: float(ff.jacobian_determinant(ONE_P, np.array([q1, q2])))  # noqa: E731
    grid = np.linspace(-np.pi, np.pi, 721)

    def inner_branch_radius(q1: float) -> float:  # the branch of det = 0 that reaches |r_E| < 0.6 (near q2 = 165°)
        values = ff.jacobian_determinant(ONE_P, np.stack([np.full_like(grid, q1), grid], axis=-1))
        radii = [
            float(radius_fk(ONE_P, [q1, brentq(lambda x: det(q1, x), grid[k], grid[k + 1], xtol=1e-14)], 0))
            for k in range(grid.size - 1)
            if values[k] * values[k + 1] < 0.0
        ]
        inner = [r for r in radii if r < 0.6]
        return max(inner) if inner else -1.0

    coarse = np.linspace(-np.pi, np.pi, 73)
    start = coarse[int(np.argmax([inner_branch_radius(q1) for q1 in coarse]))]
    best = minimize_scalar(
        lambda q1: -inner_branch_radius(q1), bounds=(start - 0.1, start + 0.1), method="bounded", options={"xatol": 1e-10}
    )
    assert picked["92.T6.PIW_min"]["ours"] == pytest.approx(-best.fun, abs=1e-8)
    # the outer branch's lowest radius is the arm stretched with the spacecraft term opposite: |-α + β + γ|
    assert picked["92.T6.PIW_max"]["ours"] == pytest.approx(-alpha + beta + gamma, abs=1e-9)


# ----------------------------------------------------------------------------------------------------------------- §V
def test_section5_capture_example(rows: dict[str, dict[str, Any]], results: Results1992) -> None:
    picked = show(rows, "92.S5.")
    # R_plus: our rule centres AB radially in the PIW (0.54506); the printed 0.540 = M/(M + m_p) * 1 m: the paper
    # picked a round approach distance (as_printed agrees). approach_distance 1.009 rounds to the printed 1.
    # q1/q2: max |det J*| is at q1 = 90.5° (91.3° at R+ = 0.540) on a very flat family; 79° is 0.8 % lower.
    # theta: the paper's -109° does not put the end effector at (R+, 0) at its own posture (that needs -111.8°).
    check_agreement(picked, {"92.S5.R_plus", "92.S5.q1_deg", "92.S5.q2_deg", "92.S5.theta_deg"})
    plan = results.plan
    r_in, r_out = plan.piw.R_min, plan.piw.R_max
    assert r_in is not None and r_out is not None
    s, length = r_in + r_out, 0.25
    r_plus = (s * s - length**2) / (2.0 * s)  # R+ - r_in = r_out - sqrt(R+² + L²)
    assert picked["92.S5.R_plus"]["ours"] == pytest.approx(r_plus, abs=1e-9)
    assert picked["92.S5.approach_distance"]["ours"] == pytest.approx((470.0 + 400.0) / 470.0 * r_plus, abs=1e-9)
    assert picked["92.S5.R_plus.as_printed"]["ours"] == pytest.approx(470.0 / 870.0, abs=1e-12)
    alpha, beta, gamma = np.real(ff.planar.position_coefficients(ONE_P, 0))

    def eq21(q1: float, q2: float) -> float:  # eq. 21 written out
        return float(
            np.sqrt(
                alpha**2
                + beta**2
                + gamma**2
                + 2 * alpha * beta * np.cos(q1)
                + 2 * alpha * gamma * np.cos(q1 + q2)
                + 2 * beta * gamma * np.cos(q2)
            )
        )

    # the optimum by a dense scan of both families (brentq on eq. 21 for q2 at each q1), independent of SLSQP
    best = (0.0, 0.0, 0.0)
    for q1 in np.radians(np.arange(80.0, 100.0, 0.01)):
        for lo, hi in ((0.0, np.pi), (-np.pi, 0.0)):
            if (eq21(q1, lo) - r_plus) * (eq21(q1, hi) - r_plus) < 0.0:
                q2 = brentq(lambda x, q1=q1: eq21(q1, x) - r_plus, lo, hi, xtol=1e-14)
                d = abs(float(ff.jacobian_determinant(ONE_P, np.array([q1, q2]))))
                if d > best[0]:
                    best = (d, q1, q2)
    assert picked["92.S5.q1_deg"]["ours"] == pytest.approx(np.degrees(best[1]), abs=0.02)
    assert picked["92.S5.q2_deg"]["ours"] == pytest.approx(np.degrees(best[2]), abs=0.02)
    r_e = ff.end_effector_positions(
        ONE_P, np.radians([picked["92.S5.q1_deg"]["ours"], picked["92.S5.q2_deg"]["ours"]]), method="recursive"
    )[0]
    assert picked["92.S5.theta_deg"]["ours"] == pytest.approx(-np.degrees(np.arctan2(r_e[1], r_e[0])), abs=1e-9)
    # as printed: eq. 21 at the printed R+ = 0.540 and q1 = 79° gives the printed q2 = 97.97°
    q2_79 = brentq(lambda x: eq21(np.radians(79.0), x) - 0.540, 0.0, np.pi, xtol=1e-14)
    assert picked["92.S5.q2_deg.as_printed"]["ours"] == pytest.approx(np.degrees(q2_79), abs=1e-9)
    # and θ at the paper's own posture is -111.8°, not the printed -109°
    r_79 = ff.end_effector_positions(ONE_P, np.array([np.radians(79.0), q2_79]), method="recursive")[0]
    assert -np.degrees(np.arctan2(r_79[1], r_79[0])) == pytest.approx(-111.77, abs=0.01)
    # the maximum stays near 91° whatever the payload inertia (so 79° is not an inertia assumption)
    base = ff.models.papadopoulos1992(arms=1)
    for inertia in (1e-3, 200.0):
        q1_grid = np.radians(np.arange(0.0, 180.0, 0.05))
        fam = capture_families(base.with_payload(0, mass=400.0, inertia=inertia), 0, 0.540, q1_grid)
        assert 89.0 < np.degrees(q1_grid[np.nanargmax(np.abs(fam.det[:, 0]))]) < 93.0

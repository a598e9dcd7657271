"""Papadopoulos 1992, the coefficients α-ε of eq. 18 (Tables II and IV) and of eq. 20 (§V).

Ours are ``ff.planar.position_coefficients(model, end_effector)``: the real
parts, in body order spacecraft, arm-1 link 1, arm-1 link 2, arm-2 link 1,
arm-2 link 2. For arm 1 that is the paper's α, β, γ, δ, ε; for arm 2 the paper
also orders α (spacecraft), β, γ (arm-1 links), δ, ε (its own links).

Each test prints a table (id, paper, ours, agrees) with agrees = (ours rounded
to the printed decimals == printed). Entries that agree are asserted to agree;
the ones that do not are asserted explicitly, together with an independent hand
computation from the paper's own chain formulas (eqs. 5-9, with the outboard
mass fractions μ*), which ours equals to 1e-12 for every entry. The model is
never tuned to the printed numbers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import freefloat as ff

# 1992 Table Ia/Ib: spacecraft 400 kg with the arms' first joints at r_0 = ±0.5 m
# (the signs that α⁽¹⁾ = 0.5, α⁽²⁾ = -0.5 imply); every link l = r = 0.5 m.
M0 = 400.0
MOUNTS = (0.5, -0.5)
LINK_MASSES = (40.0, 30.0)
LENGTH = 0.5
PAYLOAD = 400.0  # kg, grasped at its CM by the end effector of arm 1 (1992 §IV, §V)


def hand_coefficients(arms: int, payload: float) -> dict[int, list[float]]:
    """α-ε of every arm from 1992 eqs. 5-10, by hand, for the Table I system with ``arms`` arms.

    A payload held at the tip of arm 1 becomes part of its last link (§IV), which
    moves that link's CM towards the tip: l_2 and r_2 change, the link length does not.
    """
    # Links as (l, r, m) with l, r signed along the link: l from the CM to the inboard
    # joint (negative), r from the CM to the outboard joint (positive).
    chains = []
    for m in range(arms):
        links = [(-LENGTH, LENGTH, LINK_MASSES[0]), (-LENGTH, LENGTH, LINK_MASSES[1])]
        if m == 0 and payload > 0.0:
            m2 = LINK_MASSES[1] + payload
            d = (LINK_MASSES[1] * LENGTH + payload * 2 * LENGTH) / m2  # new CM of link 2 from its joint
            links[1] = (-d, 2 * LENGTH - d, m2)
        chains.append(links)
    total = M0 + sum(mass for links in chains for (_, _, mass) in links)  # eq. 7

    def mu(m: int, i: int) -> float:  # eq. 6: outboard mass after joint i (1-based) of arm m
        return sum(mass for (_, _, mass) in chains[m][i - 1 :]) / total

    c0 = sum(MOUNTS[m] * mu(m, 1) for m in range(arms))  # eq. 5a
    r0_star = [MOUNTS[m] - c0 for m in range(arms)]  # eq. 8a
    c, r_star, l_star, c_star = {}, {}, {}, {}
    for m in range(arms):
        for i, (l_i, r_i, _) in enumerate(chains[m], start=1):
            mu_next = mu(m, i + 1) if i < len(chains[m]) else 0.0
            c[m, i] = l_i * (1.0 - mu(m, i)) + r_i * mu_next  # eq. 5b
            r_star[m, i] = r_i - c[m, i]  # eq. 9, i < k
            c_star[m, i] = -c[m, i]  # eq. 9, i = k
            l_star[m, i] = l_i - c[m, i]  # eq. 9, i > k

    out = {}
    for m in range(arms):
        n_m = len(chains[m])
        own = [r_star[m, i] for i in range(1, n_m)] + [c_star[m, n_m] + chains[m][-1][1]]  # eq. 10: r_E = ρ_N + r_N
        others = {o: [l_star[o, i] for i in range(1, len(chains[o]) + 1)] for o in range(arms) if o != m}
        row = [r0_star[m]]
        for o in range(arms):  # body order: arm 1 links, then arm 2 links
            row += own if o == m else others[o]
        out[m] = row
    return out


@dataclass(frozen=True)
class Entry:
    id: str
    paper: str  # as printed
    ours: float
    hand: float

    @property
    def decimals(self) -> int:
        return len(self.paper.split(".")[1]) if "." in self.paper else 0

    @property
    def agrees(self) -> bool:
        return round(self.ours, self.decimals) == float(self.paper)


def table(printed: dict[int, list[str]], model: ff.Model, hand: dict[int, list[float]], names: str) -> list[Entry]:
    entries = []
    for m, row in printed.items():
        coeffs = ff.planar.position_coefficients(model, m)
        np.testing.assert_array_equal(coeffs.imag, 0.0)
        assert len(coeffs) == len(row)
        for name, paper, ours, by_hand in zip(names, row, coeffs.real, hand[m], strict=True):
            entries.append(Entry(f"{name}({m + 1})", paper, float(ours), by_hand))
    print("\n  id      paper     ours      agrees")
    for e in entries:
        print(f"  {e.id:7s} {e.paper:>8s}  {e.ours:+.5f}  {e.agrees}")
    return entries


def check(entries: list[Entry], known_disagreements: set[str]) -> None:
    for e in entries:  # ours is the paper's own chain formula, evaluated exactly
        assert abs(e.ours - e.hand) < 1e-12, e
    agree = [e for e in entries if e.agrees]
    for e in agree:
        assert round(e.ours, e.decimals) == float(e.paper), e
    disagree = {e.id for e in entries if not e.agrees}
    assert disagree == known_disagreements, f"disagreements {sorted(disagree)}, expected {sorted(known_disagreements)}"
    for e in entries:
        if e.id in known_disagreements:  # the printed value is not the chain formula's value
            assert round(e.hand, e.decimals) != float(e.paper), e


def test_table_ii_coefficients_without_payload() -> None:
    printed = {0: ["0.5", "0.907", "0.972", "-0.093", "-0.028"], 1: ["-0.5", "-0.093", "-0.028", "0.907", "0.972"]}
    entries = table(printed, ff.models.papadopoulos1992(), hand_coefficients(2, 0.0), "αβγδε")
    check(entries, known_disagreements=set())


def test_table_iv_coefficients_with_a_400_kg_payload_in_arm_1() -> None:
    printed = {0: ["0.287", "0.522", "0.559", "-0.053", "-0.016"], 1: ["-0.713", "-0.478", "-0.491", "0.947", "0.984"]}
    model = ff.models.papadopoulos1992().with_payload(0, mass=PAYLOAD, inertia=25.0)
    hand = hand_coefficients(2, PAYLOAD)
    entries = table(printed, model, hand, "αβγδε")
    # Three printed entries are not what eqs. 5-9 give for the printed data:
    #  γ⁽²⁾: printed -0.491, eqs. 5-9 give -0.4415. The arm-1 link-2 coefficient is c*_2 + r_2 = r_2 - c_2
    #        for end effector 1 (eq. 10) and l*_2 = l_2 - c_2 for end effector 2 (eq. 9), so
    #        γ⁽¹⁾ - γ⁽²⁾ = r_2 - l_2 = the link length, 1.000 m. Printed: 0.559 + 0.491 = 1.050;
    #        the β, δ, ε pairs give 1.000 as they must. A misprint of γ⁽²⁾ (Table V's R_max⁽²⁾ = 3.613
    #        is the sum of the printed magnitudes, so it inherits it).
    #  β⁽¹⁾, β⁽²⁾: printed 0.522, -0.478; eqs. 5-9 give 0.52128 and -0.47872 (c_1 = -1/47 m exactly).
    #        The printed pair still differs by 1.000, so the paper placed the barycenter of arm-1
    #        link 1 about 0.7 mm off; the printed values are not a rounding of the chain formula.
    check(entries, known_disagreements={"β(1)", "β(2)", "γ(2)"})
    by_id = {e.id: e for e in entries}
    for name, own, other in (("β", 1, 2), ("γ", 1, 2), ("δ", 2, 1), ("ε", 2, 1)):
        # A link as seen from its own end effector minus as seen from the other one: r* - l* (or r - l).
        ours_pair = by_id[f"{name}({own})"].ours - by_id[f"{name}({other})"].ours
        printed_pair = float(by_id[f"{name}({own})"].paper) - float(by_id[f"{name}({other})"].paper)
        assert abs(ours_pair - 1.0) < 1e-12  # the length of a 1 m link
        assert abs(printed_pair - (1.050 if name == "γ" else 1.000)) < 1e-9
    assert round(by_id["β(1)"].ours, 4) == 0.5213 and round(by_id["γ(2)"].ours, 4) == -0.4415


def test_section_v_coefficients_after_capture_with_one_arm() -> None:
    """1992 §V: one arm, 400 kg / 25 kg m² payload at its CM: α = 0.230, β = 0.483, γ = 0.523 m."""
    model = ff.models.papadopoulos1992(arms=1).with_payload(0, mass=PAYLOAD, inertia=25.0)
    entries = table({0: ["0.230", "0.483", "0.523"]}, model, hand_coefficients(1, PAYLOAD), "αβγ")
    check(entries, known_disagreements=set())


def test_hand_computation_reproduces_the_no_payload_symmetry() -> None:
    """A guard on the hand computation itself: without payload the two arms mirror each other."""
    hand = hand_coefficients(2, 0.0)
    assert hand[0][0] == -hand[1][0] == 0.5
    np.testing.assert_allclose(hand[0][1:3], hand[1][3:5], rtol=0, atol=1e-15)
    np.testing.assert_allclose(hand[0][3:5], hand[1][1:3], rtol=0, atol=1e-15)
    np.testing.assert_allclose(hand[0][1:], [49 / 54, 35 / 36, -5 / 54, -1 / 36], rtol=0, atol=1e-15)

"""Papadopoulos 1992's printed numbers, typed from the paper, and where freefloat documents a difference from them.

Source: ``../shared/papers/papadopoulos-1992-large-payload-manipulation.md`` (Tables II-VI and the §V text). These
are typed here, independently of :data:`freefloat.papers.paper1992.PRINTED` (which tests/papers/test_1992_report.py
checks against them), so that a test of a printed number compares the code with the paper, not with itself.
A number is a string: its digits give its precision (half a unit of the last digit).
"""

from __future__ import annotations

COEFFICIENTS = ("alpha", "beta", "gamma", "delta", "epsilon")
LIMITS = ("R_max", "R_min", "GW_max", "GW_min")

#: Papadopoulos 1992 as printed (strings: the printed precision), typed from the paper; None where it prints "n/a".
#: Tables III and V print the header R'_max twice (R'_max, R''_max in V): the 3rd column is R'_max, the 4th R'_min.
PAPER: dict[str, str | None] = {
    # Table II, coefficients α-ε without payload
    **dict(zip([f"92.T2.arm1.{k}" for k in COEFFICIENTS], ["0.5", "0.907", "0.972", "-0.093", "-0.028"], strict=True)),
    **dict(zip([f"92.T2.arm2.{k}" for k in COEFFICIENTS], ["-0.5", "-0.093", "-0.028", "0.907", "0.972"], strict=True)),
    # Table III, workspace limits without payload (both arms alike)
    **{f"92.T3.arm{m}.{k}": v for m in (1, 2) for k, v in zip(LIMITS, ["2.50", "0.314", "1.258", "0.686"], strict=True)},
    # Table IV, coefficients with the 400 kg payload in arm 1
    **dict(zip([f"92.T4.arm1.{k}" for k in COEFFICIENTS], ["0.287", "0.522", "0.559", "-0.053", "-0.016"], strict=True)),
    **dict(zip([f"92.T4.arm2.{k}" for k in COEFFICIENTS], ["-0.713", "-0.478", "-0.491", "0.947", "0.984"], strict=True)),
    # Table V, workspace limits with the payload
    **dict(zip([f"92.T5.arm1.{k}" for k in LIMITS], ["1.437", "0.181", "0.725", "0.393"], strict=True)),
    **dict(zip([f"92.T5.arm2.{k}" for k in LIMITS], ["3.613", "0.219", None, None], strict=True)),
    # §V text: "α = 0.230m, β = 0.483m, γ = 0.523m"
    "92.S5.alpha": "0.230",
    "92.S5.beta": "0.483",
    "92.S5.gamma": "0.523",
    # Table VI: R_max, R_min, R_PIWmax, R_PIWmin, R'_max, R'_min
    **dict(
        zip(
            [f"92.T6.{k}" for k in ("R_max", "R_min", "PIW_max", "PIW_min", "GW_max", "GW_min")],
            ["1.236", "0.190", "0.776", "0.370", "0.776", "0.270"],
            strict=True,
        )
    ),
    # §V text: "R+ = 0.540m", "R = 1m", "[θ, q1, q2] = [-109°, 79°, 97.97°]"
    "92.S5.R_plus": "0.540",
    "92.S5.approach_distance": "1",
    "92.S5.q1_deg": "79",
    "92.S5.q2_deg": "97.97",
    "92.S5.theta_deg": "-109",
}

#: Where ours differs from the printed number beyond the printed precision: ours as docs/workspaces.md states it (its
#: digits give the tolerance; "0" is an exact zero). Why, in short (each row's note and the docs give the evidence):
#: T4 beta: an arithmetic slip in the paper (b_1 = 0.478); T4.arm2.gamma: a misprint (γ⁽¹⁾ - γ⁽²⁾ must be 1 m);
#: R_min: the true minimum of eq. 15a is 0, the paper's are collinear minima (the .collinear rows) on its 3-decimal
#: coefficients; T3 GW: the paper rounded Table II first; T5: the paper used its slip and misprint; T6.PIW_min 0.3689
#: vs 0.370: not reproducible by any assumption we know; §V: the paper's R+ is a round R = 1 m, |det J*| is flat
#: along the eq. 21 family (q1, q2), and its θ does not satisfy eq. 20 at its own posture.
DOCUMENTED: dict[str, str] = {
    "92.T4.arm1.beta": "0.52128",
    "92.T4.arm2.beta": "-0.47872",
    "92.T4.arm2.gamma": "-0.44149",
    **{
        f"92.T3.arm{m}.{k}": v
        for m in (1, 2)
        for k, v in (("R_min", "0"), ("R_min.collinear", "0.31481"), ("GW_max", "1.25926"), ("GW_min", "0.68519"))
    },
    "92.T5.arm1.R_max": "1.43617",
    "92.T5.arm1.R_min": "0",
    "92.T5.arm1.GW_max": "0.72340",
    "92.T5.arm1.GW_min": "0.39362",
    "92.T5.arm2.R_max": "3.56383",
    "92.T5.arm2.R_min": "0",
    "92.T5.arm2.R_min.collinear": "0.17021",
    "92.T6.R_min": "0",
    "92.T6.PIW_min": "0.36886",
    "92.S5.R_plus": "0.54506",
    "92.S5.q1_deg": "90.52",
    "92.S5.q2_deg": "92.29",
    "92.S5.theta_deg": "-123.00",
}


def half_unit(text: str) -> float:
    """Half a unit of the last digit of a number as written: the rounding error it allows."""
    decimals = len(text.split(".")[1]) if "." in text else 0
    return 0.5 * 10.0**-decimals


def matches(value: float, text: str) -> bool:
    """``value`` rounds to ``text`` (a number as written; "0" is an exact zero, to 1e-9)."""
    tolerance = 1e-9 if text == "0" else half_unit(text) * (1.0 + 1e-9)
    return abs(value - float(text)) <= tolerance


def paper_or_documented(key: str, ours: float) -> None:
    """Assert that ``ours`` agrees with the paper's ``key`` at the printed precision, or, where docs/workspaces.md
    documents a difference (:data:`DOCUMENTED`), that it is the documented value and does differ from the paper's."""
    printed = PAPER[key.removesuffix(".as_printed").removesuffix(".collinear")]
    assert printed is not None, f"{key}: the paper prints n/a"
    if key in DOCUMENTED:
        assert matches(ours, DOCUMENTED[key]), f"{key}: ours {ours} is not the documented {DOCUMENTED[key]} (docs/workspaces.md)"
        assert abs(ours - float(printed)) > half_unit(printed), f"{key}: ours {ours} now agrees with the paper's {printed}: update the docs"
    else:
        assert matches(ours, printed), f"{key}: ours {ours} is not the paper's {printed} at its printed precision"

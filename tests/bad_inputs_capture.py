"""Bad-input cases of issue 40: the capture sequence keys, targets, impact, detumbling, wheels (gathered by tests/test_bad_inputs.py)."""

from __future__ import annotations

from bad_case import Case

CASES: list[Case] = []

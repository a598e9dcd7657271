"""Bad-input cases of issue 40: campaign specs and storage, the cluster, capture campaigns (gathered by tests/test_bad_inputs.py)."""

from __future__ import annotations

from bad_case import Case

CASES: list[Case] = []

"""Bad-input cases of issue 40: models by relative, spaced, unicode and symlinked paths; rollouts; the CLI's warnings and --out."""

from __future__ import annotations

from bad_case import Case

CASES: list[Case] = []

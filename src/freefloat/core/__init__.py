"""The bottom layer: the model and its description, barycentric quantities, state, conventions, errors.

- :mod:`.errors`: every error and warning class (``FreefloatError`` and its subclasses, ``NearSingularWarning``).
- :mod:`.conventions`: frames, quaternion order, velocity order, units (``ff.conventions``).
- :mod:`.model`: the immutable :class:`~freefloat.Model`; :mod:`.builder`: :class:`~freefloat.ModelBuilder`.
- :mod:`.barycentric`: barycenters, barycentric vectors l*, r*, c* (1992 eqs. 4-9), computed at build time.
- :mod:`.state`: :class:`~freefloat.State`, :class:`~freefloat.Actuation`, :class:`~freefloat.ActuatorLimits`.

Layer: imports numpy and scipy only (a contract in pyproject.toml, checked by ``lint-imports``).
"""

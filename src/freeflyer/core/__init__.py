"""The bottom layer: the model and its description, barycentric quantities, state, conventions, errors.

- :mod:`.errors`: every error and warning class (``FreeflyerError`` and its subclasses, ``NearSingularWarning``).
- :mod:`.conventions`: frames, quaternion order, velocity order, units (``ff.conventions``).
- :mod:`.model`: the immutable :class:`~freeflyer.Model`; :mod:`.builder`: :class:`~freeflyer.ModelBuilder`.
- :mod:`.barycentric`: barycenters, barycentric vectors l*, r*, c* (1992 eqs. 4-9), computed at build time.
- :mod:`.state`: :class:`~freeflyer.State`, :class:`~freeflyer.Actuation`, :class:`~freeflyer.ActuatorLimits`.

Layer: imports numpy and scipy only (a contract in pyproject.toml, checked by ``lint-imports``).
"""

"""Workspaces of free-floating space robots (Papadopoulos 1992 §III-IV), for any tree: ``ff.workspace``.

Every workspace here is a set of distances from the **system CM**: the
distance |r_E| of an end effector from the system CM does not depend on the
spacecraft attitude, so each workspace is a spherical shell (an annulus for a
planar model) or a union of them, centred on the CM, which does not move.

* :func:`reachable_workspace`: R_min = min_q |r_E|, R_max = max_q |r_E| (eq. 15).
* :func:`guaranteed_workspace`: the shell R'_min..R'_max of eq. 16, the
  points the end effector reaches whatever the rest of the system does, or
  ``exists=False`` with the reason.
* :func:`path_independent_workspace`: the radii reached in a dynamic
  singularity (det ⁰J* = 0, eq. 17), the path-dependent workspace (PDW), and
  the path-independent workspace PIW = reachable radii minus PDW radii.
* :func:`payload_effect`: workspaces before and after grasping a payload (§IV).
* :func:`collinear_radius_range`: min and max of |r_E| over q in {0, π}^N,
  the reading of eq. 15 that reproduces the paper's printed R_min values.
* :func:`jacobian_determinant_map`: det J* over a grid of two joint angles.
* :func:`workspace_limits`: every limit above for every end effector of a
  model (``freefloat workspace``), with its plots and JSON.
* :class:`SingularityCriterion`: which rows of J* (full or translational)
  and which measure (det, smallest singular value, manipulability) count as
  singular, with a threshold; accepted by the PIW and the capture planning.
* :func:`workspace_cloud` and :func:`plot_workspace_sections`: spatial arms
  drawn in 3D (sections of the shells through the CM, point clouds).

Closed forms. For a planar model whose joints are all free (no limits, or a
full turn), r_E = Σ_i a_i exp(iφ_i) (eq. 18 generalised: one barycentric
vector a_i per body, φ_i the absolute angle of body i). The absolute angles
are independent (the map (θ, q) -> φ is triangular with unit diagonal), so
|r_E| ranges over [max(0, 2 max|a_i| - Σ|a_i|), Σ|a_i|]: the polygon rule
(:func:`free_sum_radii`). Everything else is computed by dense batched
sampling plus polishing (see ``freefloat.analysis._workspace_search``) and reports
the method and its accuracy. All distances are in m; angles in rad.

This module gathers the public names; the computations live in the private
modules ``_workspace_reach`` (eqs. 15-16), ``_workspace_singular`` (eq. 17,
§IV), ``_workspace_search`` (sampling and polishing), ``_workspace_results``
(the frozen results and their ``.plot``), and in :mod:`.singularity` and
:mod:`.workspace_report`.
"""

from __future__ import annotations

from ._workspace_reach import (
    collinear_radii,
    collinear_radius_range,
    end_effector_radius,
    free_sum_radii,
    guaranteed_radii,
    guaranteed_workspace,
    reachable_workspace,
    singularity_measure,
)
from ._workspace_results import (
    GuaranteedRadii,
    GuaranteedWorkspace,
    PathIndependentWorkspace,
    PayloadEffect,
    RadiusRange,
    ReachableWorkspace,
)
from ._workspace_singular import path_independent_workspace, payload_effect
from .singularity import DeterminantMap, DeterminantMapArtists, SingularityCriterion, jacobian_determinant_map
from .workspace_3d import WorkspaceCloud, plot_workspace_sections, workspace_cloud
from .workspace_report import WorkspaceLimits, limits_json, workspace_limits, write_workspace_plots

__all__ = [
    "DeterminantMap",
    "DeterminantMapArtists",
    "GuaranteedRadii",
    "GuaranteedWorkspace",
    "PathIndependentWorkspace",
    "PayloadEffect",
    "RadiusRange",
    "ReachableWorkspace",
    "SingularityCriterion",
    "WorkspaceCloud",
    "WorkspaceLimits",
    "collinear_radii",
    "collinear_radius_range",
    "end_effector_radius",
    "free_sum_radii",
    "guaranteed_radii",
    "guaranteed_workspace",
    "jacobian_determinant_map",
    "limits_json",
    "path_independent_workspace",
    "payload_effect",
    "plot_workspace_sections",
    "reachable_workspace",
    "singularity_measure",
    "workspace_cloud",
    "workspace_limits",
    "write_workspace_plots",
]

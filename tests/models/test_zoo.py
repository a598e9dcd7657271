"""The model zoo (issue 12): every model loads cleanly, matches Pinocchio, and carries its provenance.

The comparison with Pinocchio is ``tests/oracle/test_pinocchio_core.compare`` (mass, CM,
end-effector positions about the CM, momenta, kinetic energy, H+, J*, J+, a random point
Jacobian; engine and barycentric forms) on five random states per model.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import freefloat as ff
from freefloat.core.model import inertia_defect, nearest_physical_inertia
from freefloat.models import ZOO, provenance
from oracle.test_pinocchio_core import compare, pinocchio_of

#: name -> (joints, end effectors) the published systems have
SHAPES = {"ssrms-station": (7, 1), "ets7": (6, 1), "dual-arm-servicer": (14, 2), "astrobee-arm": (2, 1)}


@pytest.mark.parametrize("name", sorted(ZOO))
def test_zoo_model_matches_pinocchio(name: str) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a zoo model loads without a warning: its corrections are declared
        model = ff.models.load_model(name)
    assert (model.n_joints, model.n_end_effectors) == SHAPES[name]
    assert model.end_effector_rule == "named"
    assert ff.generalized_jacobian(model, np.zeros(model.n_joints)).shape == (6 * SHAPES[name][1], SHAPES[name][0])
    system = pinocchio_of(model)
    rng = np.random.default_rng(sum(map(ord, name)))
    for _ in range(5):
        compare(model, system, rng)


@pytest.mark.parametrize("name", sorted(ZOO))
def test_zoo_model_has_its_provenance(name: str) -> None:
    notes = provenance(name).lower()
    assert "licen" in notes and ("source" in notes or "sources" in notes)
    assert "chosen" in notes  # what was not published is said to be chosen


def test_ets7_corrections_are_computed_from_the_published_inertias() -> None:
    model = ff.models.ets7()
    assert [c["where"].split("(")[-1].split(")")[0] for c in model.corrections] == ["link2", "link3", "link5"]
    for record in model.corrections:
        given = np.array(record["given"])
        assert "triangle inequality" in (inertia_defect(given) or "")
        used = nearest_physical_inertia(given)
        np.testing.assert_allclose(record["used"], used, rtol=0, atol=1e-12)
        body = record["where"].split("(")[-1].split(")")[0]
        np.testing.assert_allclose(model.inertia[model.body_index(body)], used, rtol=0, atol=1e-12)
        moments = np.linalg.eigvalsh(used)
        assert moments[2] == pytest.approx(moments[0] + moments[1], rel=1e-9)  # on the boundary: the smallest change
        assert 0.03 < record["relative_change"] < 0.05 and record["why"]


def test_declared_correction_of_a_physical_inertia_is_refused(tmp_path) -> None:
    text = """
name = "x"
[[bodies]]
name = "bus"
mass = 100.0
inertia = [10.0, 10.0, 10.0]
[[bodies]]
name = "arm"
mass = 5.0
com = [0.5, 0.0, 0.0]
[[joints]]
name = "q"
parent = "bus"
child = "arm"
origin = [0.5, 0.0, 0.0]
[[corrections]]
body = "arm"
given = [[0.1, 0.0, 0.0], [0.0, 0.2, 0.0], [0.0, 0.0, 0.2]]
why = "test"
"""
    path = tmp_path / "x.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ff.ModelError, match=r"corrections\[0\]\.given: is a physical inertia: there is nothing to correct"):
        ff.load(path)


def test_printed_names_are_the_names_the_cli_takes() -> None:
    """``model.name`` (what inspect, reports and outputs print) loads the same model again, for every built-in."""
    from freefloat.models import BUILTIN_MODELS, load_model

    for key in BUILTIN_MODELS:
        model = load_model(key)
        assert load_model(model.name) is model, (key, model.name)
    assert ff.models.astrobee_arm().name == "astrobee-arm" and ff.models.ssrms_station().name == "ssrms-station"


def test_strict_refuses_a_built_in_model_whose_data_was_corrected() -> None:
    from freefloat.models import load_model

    with pytest.raises(ff.ModelError, match=r"needed 3 correction\(s\) .* which strict refuses"):
        load_model("ets7", strict=True)
    assert load_model("papadopoulos1992", strict=True) is load_model("papadopoulos1992")  # nothing corrected: accepted

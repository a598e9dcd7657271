"""The specialiser (ff.mechanics.specialise): its tracing rules, the code it emits, its sin/cos, its kernels.

The specialised kernels are the engine's own recursions traced on symbols (engine/specialise/trace.py),
emitted as SIMD code over blocks of configurations (engine/specialise/build.py). Checked here: each
folding rule, common-subexpression and dead-code elimination; the emitted code (run as plain
Python) against the graph evaluated on floats and against the generic kernels, for random trees;
the vectorisable sin/cos against the C library in ulp; and the compiled kernels against
Pinocchio, against the generic kernels at batch sizes around the block size, on payload
variants, through failures, and with a broken cache file.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path

import numba
import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import freefloat as ff
from freefloat.engine import calls as _engine
from freefloat.engine.cache import CacheWarning, cache_dir
from freefloat.engine.layout import tree
from freefloat.engine.specialise import build as _specialise
from freefloat.engine.specialise import lanes as _lanes
from freefloat.engine.specialise.trace import Graph, Sym
from freefloat.io.oracles import pinocchio_configuration, to_pinocchio
from trees import build_random_model, random_trees

LANES = _lanes.LANES


# ----------------------------------------------------------------- tracing rules
def test_folding_rules() -> None:
    g = Graph()
    x, y = g.input("W", 0), g.input("W", 1)
    assert x * 0.0 == 0.0 and 0.0 * x == 0.0 and 0.0 / x == 0.0
    assert (x + 0.0).index == x.index and (0.0 + x).index == x.index and (x - 0.0).index == x.index
    assert (x * 1.0).index == x.index and (x / 1.0).index == x.index
    assert g.ops[(0.0 - x).index] == "neg" and g.ops[(x * -1.0).index] == "neg"
    minus = -x
    assert (-minus).index == x.index
    assert (x - x) == 0.0
    assert 2.0 * 3.0 + Sym.add(1.0, 2.0) == 9.0  # numbers fold to numbers
    assert isinstance(x + y, Sym) and g.ops[(x + y).index] == "+"


def test_common_subexpressions_are_one_node() -> None:
    g = Graph()
    x, y = g.input("W", 0), g.input("W", 1)
    a = x * y
    count = len(g.ops)
    assert (y * x).index == a.index and (x * y).index == a.index  # + and * ordered: one node
    assert (x + y).index == (y + x).index
    assert (x - y).index != (y - x).index  # not commutative
    assert len(g.ops) == count + 3
    assert g.input("W", 0).index == x.index


def test_numbers_and_nodes_are_told_apart() -> None:
    """Python has 2 == 2.0 and 0.0 == -0.0: the hash-consing key must not, or x * 2.0 would be x * (node 2)."""
    g = Graph()
    x, _, z = g.input("W", 0), g.input("W", 1), g.input("W", 2)
    assert z.index == 2
    by_node, by_number = x * z, x * 2.0
    assert by_node.index != by_number.index
    val = g.evaluate({"W": np.array([3.0, 0.0, 7.0])}, [by_node.index, by_number.index])
    assert val[by_node.index] == 21.0 and val[by_number.index] == 6.0
    assert (x / 0.0).index != (x / -0.0).index


def test_dead_code_is_dropped() -> None:
    g = Graph()
    x, y = g.input("W", 0), g.input("W", 1)
    used = x * y + 1.0
    unused = x / y
    keep = g.live([used.index])
    assert keep[used.index] and keep[x.index] and keep[y.index]
    assert not keep[unused.index]
    source, _ = _specialise.emit(g, [used], 2)
    assert " / " not in source


def test_branches_on_symbols_are_guards_or_errors() -> None:
    g = Graph()
    x = g.input("W", 0)
    if not x > 0.0:  # the Cholesky pivot test: assumed true, recorded
        raise AssertionError
    assert len(g.guards) == 1 and g.ops[g.guards[0]] == ">"
    with pytest.raises(TypeError, match="branch on a traced value"):
        bool(x)
    with pytest.raises(TypeError):
        float(x)
    with pytest.raises(TypeError, match="== on a traced value"):
        _ = x == 1.0
    with pytest.raises(TypeError):
        _ = x >= 1.0


def test_a_select_on_data_is_one_pick_node() -> None:
    """The engine's measures select on data only through ``_configuration._pick`` (a if x > y else b): traced, a pick of
    numbers is chosen at once, one of a symbol is one node (the same choice made twice: one node), evaluated and emitted
    as that select; a pick between two equal values is the value."""
    from freefloat.engine.specialise.trace import _pick, traced

    assert traced().configuration._reduce_views.__globals__["_pick"] is _pick
    g = Graph()
    x, y = g.input("W", 0), g.input("W", 1)
    assert _pick(2.0, 1.0, x, y).index == x.index and _pick(1.0, 2.0, x, y).index == y.index
    assert _pick(x, 0.0, y, y).index == y.index
    chosen = _pick(x, 0.0, x, -x)  # |x|
    assert g.ops[chosen.index] == "pick" and _pick(x, 0.0, x, -x).index == chosen.index
    assert isinstance(_pick(x, 0.0, 0.0, -0.0), Sym)  # 0.0 and -0.0 are two values
    for w0, expected in ((-3.0, 3.0), (2.5, 2.5)):
        assert g.evaluate({"W": np.array([w0, 0.0])}, [chosen.index])[chosen.index] == expected
        source, _ = _specialise.emit(g, [chosen], 2)
        assert _run_emitted(source, np.repeat(np.array([w0, 0.0, np.nan]), LANES), np.empty(0))[2 * LANES] == expected


# ----------------------------------------------------------------- emitted code, run as Python
def _run_emitted(source: str, w: np.ndarray, data: np.ndarray) -> np.ndarray:
    namespace: dict = {"math": math}
    exec(source, namespace)
    w = w.copy()
    namespace["lane"](w, data)
    return w


@settings(max_examples=25)
@given(model=random_trees(max_arms=2, max_joints=3, prismatic=0.3), seed=st.integers(0, 2**16))
def test_emitted_code_equals_the_graph_and_the_generic_kernels_on_random_trees(model: ff.Model, seed: int) -> None:
    """The emitted lane code (plain Python, its sin/cos) = the graph on floats (math.sin) = the generic kernels."""
    rng = np.random.default_rng(seed)
    t = tree(model)
    n = model.n_joints
    data = _specialise.data_vector(t)
    # J*
    g, outputs, n_in = _specialise.trace(t, "jstar")
    source, slots = _specialise.emit(g, outputs, n_in)
    q = rng.uniform(-3.0, 3.0, (LANES, n))
    w = np.zeros((n_in + len(outputs)) * LANES)
    w[: n * LANES] = q.T.ravel()
    lanes = _run_emitted(source, w, data[slots]).reshape(-1, LANES)[n_in:].T
    with _specialise.generic():
        generic = ff.generalized_jacobian(model, q).reshape(LANES, -1)
    roots = [o.index for o in outputs if isinstance(o, Sym)]
    for lane in (0, LANES - 1):
        val = g.evaluate({"W": q[lane], "data": data}, roots)
        graph = np.array([val[o.index] if isinstance(o, Sym) else o for o in outputs])
        np.testing.assert_allclose(lanes[lane], graph, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(lanes, generic, rtol=1e-12, atol=1e-12)
    # the state derivative of the rollouts, with its Cholesky guards
    g, outputs, n_in = _specialise.trace(t, "rollout")
    assert len(g.guards) == 3 + n  # one positive pivot per row of the [omega0, q] block
    source, slots = _specialise.emit(g, outputs, n_in)
    x = np.zeros((LANES, 13 + 2 * n))
    x[:, 6:10] = rng.normal(size=(LANES, 4))
    x[:, 10:] = rng.uniform(-1.0, 1.0, (LANES, 3 + 2 * n))
    u = rng.normal(size=(LANES, n + 6))
    w = np.zeros((n_in + len(outputs) + 1) * LANES)
    w[: n_in * LANES] = np.hstack([x, u]).T.ravel()
    w[-LANES:] = 1.0
    out = _run_emitted(source, w, data[slots]).reshape(-1, LANES)
    with _specialise.generic():
        generic_dx, ok = _engine.state_derivative(model, x, u)
    assert ok.all() and (out[-1] == 1.0).all()
    np.testing.assert_allclose(out[n_in:-1].T, generic_dx, rtol=1e-11, atol=1e-11)


# ----------------------------------------------------------------- sin and cos
def test_sincos_is_within_its_ulp_bound_of_the_c_library() -> None:
    """The emitted sin/cos: <= 1 ulp of libm over |q| <= 7 rad (two turns each way), <= 2 ulp over |q| <= 1e5 rad."""
    code = _specialise.SINCOS.format(x="x", t="t", sin="s", cos="c").splitlines()
    source = "def f(X, S, C):\n    for i in range(X.shape[0]):\n        x = X[i]\n" + "".join(f"        {line}\n" for line in code)
    source += "        S[i] = s\n        C[i] = c\n"
    namespace: dict = {"math": math}
    exec(source, namespace)
    f = numba.njit(error_model="numpy", fastmath={"contract"})(namespace["f"])  # as in the kernels
    rng = np.random.default_rng(0)
    k = rng.integers(-60_000, 60_000, 200_000)
    ranges = {
        "joint": (np.concatenate([rng.uniform(-7.0, 7.0, 400_000), np.arange(-4, 5) * np.pi / 4, k[:1000] % 5 * np.pi / 2]), 1.0),
        "wide": (np.concatenate([rng.uniform(-1e5, 1e5, 400_000), k * np.pi / 2, k * np.pi / 2 + rng.normal(0, 1e-9, k.size)]), 2.0),
    }
    for name, (x, bound) in ranges.items():
        s, c = np.empty_like(x), np.empty_like(x)
        f(x, s, c)
        for got, ref in ((s, np.array([math.sin(v) for v in x])), (c, np.array([math.cos(v) for v in x]))):
            ulp = np.abs(got - ref) / np.spacing(np.abs(ref))
            assert ulp.max() <= bound, (name, ulp.max(), x[np.argmax(ulp)])


# ----------------------------------------------------------------- the compiled kernels
@pytest.fixture(scope="module")
def specialised(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """Specialised kernels on, in a cache folder of this module's own (``FREEFLOAT_CACHE_DIR``, a temporary folder):
    the generated modules and numba's machine code of their kernels go there, never into the user's cache. They
    compile once per test session (the tests of this module share the folder)."""
    with pytest.MonkeyPatch.context() as env:
        env.setenv("FREEFLOAT_CACHE_DIR", str(tmp_path_factory.mktemp("freefloat-cache")))
        folder = cache_dir() / "specialised"  # where ff.mechanics.specialise keeps them: next to the generic kernels
        before = _specialise.FOLDER[0]
        _specialise.FOLDER[0] = None
        _specialise._LOADED.clear()
        _specialise._ENABLED[0] = True
        _specialise._FOUND.clear()
        try:
            yield folder
        finally:
            _specialise.FOLDER[0] = before
            _specialise._ENABLED[0] = False
            _specialise._LOADED.clear()
            _specialise._FOUND.clear()


def _prismatic_tree() -> ff.Model:
    return build_random_model(np.random.default_rng(3), [3, 2], [1, None], [None, 0], prismatic=0.4)


def test_nothing_is_compiled_unless_asked(specialised: Path) -> None:
    model = build_random_model(np.random.default_rng(99), [2, 2, 1], [None, None, None], [None, None, None])
    assert not ff.mechanics.is_specialised(model, "jstar")
    ff.generalized_jacobian(model, np.zeros((500, model.n_joints)))
    assert not (specialised / f"{_specialise.structure_key(tree(model), 'jstar')}.py").exists()
    assert not [p for p in specialised.parent.parent.rglob("*") if p.is_file()]  # nothing generated, nothing compiled there


@pytest.mark.parametrize("which", ["papadopoulos1992", "prismatic-tree"])
def test_specialised_jstar_matches_pinocchio_and_the_generic_kernels(specialised: Path, which: str) -> None:
    model = ff.models.papadopoulos1992() if which == "papadopoulos1992" else _prismatic_tree()
    ff.mechanics.specialise(model, ["jstar"])
    assert ff.mechanics.is_specialised(model, "jstar")
    rng = np.random.default_rng(5)
    n = model.n_joints
    for size in (1, 63, 64, 65, 129, _specialise.THREADS_FROM + 65):  # around the block size; one range, one per thread
        q = rng.uniform(-np.pi, np.pi, (size, n))
        fast = ff.generalized_jacobian(model, q)
        with _specialise.generic():
            slow = ff.generalized_jacobian(model, q)
        np.testing.assert_allclose(fast, slow, rtol=0, atol=1e-12 * np.abs(slow).max())
    # against Pinocchio (J* from its centroidal map and frame Jacobians), spacecraft frame
    pin_model = to_pinocchio(model)
    frames = model.end_effector_names
    data = pin_model.createData()
    for i in range(0, q.shape[0], 97):
        pq = pinocchio_configuration(model, q[i], np.array([0.0, 0.0, 0.0, 1.0]), np.zeros(3))
        ag = pin.computeCentroidalMap(pin_model, data, pq)
        pin.computeJointJacobians(pin_model, data, pq)
        pin.updateFramePlacements(pin_model, data)
        rows = []
        for f in frames:
            jac = pin.getFrameJacobian(pin_model, data, pin_model.getFrameId(f), pin.LOCAL_WORLD_ALIGNED)
            rows.append(jac)
        jac = np.vstack(rows)
        jstar = jac[:, 6:] - jac[:, :6] @ np.linalg.solve(ag[:, :6], ag[:, 6:])
        np.testing.assert_allclose(fast[i], jstar, rtol=0, atol=1e-12 * np.abs(jstar).max())


@pytest.mark.parametrize("kind", ["jstar", "hplus"])
def test_a_map_writes_its_rows_at_any_start_and_nothing_outside(specialised: Path, kind: str) -> None:
    """The map driver writes a caller's output wherever it starts within a cache line (a view into a larger array, as
    out= may be), around the block and the thread threshold: the same values to the bit, nothing written outside."""
    model = _prismatic_tree()
    t = tree(model)
    ff.mechanics.specialise(model, [kind])
    module = _specialise.find(t, kind)
    assert module is not None
    n = model.n_joints
    width = module.COLUMNS.shape[0]
    rng = np.random.default_rng(11)
    sizes = (1, 7, 8, 9, LANES - 1, LANES, LANES + 3, 5 * LANES + 17, _specialise.THREADS_FROM + 65)
    for size in sizes:
        q = rng.uniform(-np.pi, np.pi, (size, n))
        plain = np.full((size, width), np.nan)
        _specialise._run(module, size, ((q,), _specialise.data_vector(t)[module.SLOTS], plain.reshape(-1), module.COLUMNS))
        assert np.isfinite(plain).all()
        for shift in range(8):  # the output's first value at each place in a 64-byte line
            room = np.full(size * width + 16, np.nan)
            start = (-room.ctypes.data % 64) // 8 + shift
            out = room[start : start + size * width]
            _specialise._run(module, size, ((q,), _specialise.data_vector(t)[module.SLOTS], out, module.COLUMNS))
            np.testing.assert_array_equal(out.reshape(size, width), plain, err_msg=f"{kind}, {size} configurations, shift {shift}")
            assert np.isnan(room[:start]).all() and np.isnan(room[start + size * width :]).all()  # nothing written outside


def test_a_payload_variant_shares_the_kernels(specialised: Path) -> None:
    model = ff.models.papadopoulos1992()
    ff.mechanics.specialise(model, ["jstar"])
    heavy = model.with_payload(mass=150.0, inertia=np.diag([5.0, 6.0, 7.0]))
    assert _specialise.structure_key(tree(heavy), "jstar") == _specialise.structure_key(tree(model), "jstar")
    assert ff.mechanics.is_specialised(heavy, "jstar")
    q = np.random.default_rng(8).uniform(-3, 3, (300, model.n_joints))
    fast = ff.generalized_jacobian(heavy, q)
    with _specialise.generic():
        slow = ff.generalized_jacobian(heavy, q)
        other = ff.generalized_jacobian(model, q)
    np.testing.assert_allclose(fast, slow, rtol=0, atol=1e-12)
    assert np.abs(fast - other).max() > 1e-3  # the payload's mass is read, not folded


@pytest.mark.parametrize("which", ["papadopoulos1992", "prismatic-tree"])
def test_specialised_rollouts_match_the_generic_kernels(specialised: Path, which: str) -> None:
    model = ff.models.papadopoulos1992() if which == "papadopoulos1992" else _prismatic_tree()
    ff.mechanics.specialise(model, ["rollout"])
    n = model.n_joints
    rng = np.random.default_rng(4)
    k = 70  # two blocks, the second short
    state = ff.State(q=rng.uniform(-1, 1, (k, n)), qdot=rng.uniform(-0.3, 0.3, (k, n)), omega=rng.normal(scale=0.05, size=(k, 3)))
    series = rng.normal(scale=0.5, size=(k, 60, n))  # per-trajectory feed-forward (K, S, N), passed swapped: read in place
    ctrl = ff.JointPD(kp=rng.uniform(1, 5, (k, n)), kd=1.0, q_ref=0.2, feedforward=series.swapaxes(0, 1), feedforward_period=5e-3)
    limits = ff.ActuatorLimits(joint_torque=np.full(n, 3.0))
    fast = ff.rollout(model, state, 0.3, dt=1e-3, controller=ctrl, sample_period=5e-3, limits=limits, output_period=7e-3)
    with _specialise.generic():
        slow = ff.rollout(model, state, 0.3, dt=1e-3, controller=ctrl, sample_period=5e-3, limits=limits, output_period=7e-3)
    np.testing.assert_allclose(fast.q, slow.q, rtol=0, atol=1e-11)
    np.testing.assert_allclose(fast.joint_torque, slow.joint_torque, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(fast.saturated, slow.saturated)
    assert fast.saturated.any() and not fast.saturated.all()
    copied = ff.JointPD(kp=ctrl.kp, kd=1.0, q_ref=0.2, feedforward=np.ascontiguousarray(series.swapaxes(0, 1)), feedforward_period=5e-3)
    same = ff.rollout(model, state, 0.3, dt=1e-3, controller=copied, sample_period=5e-3, limits=limits, output_period=7e-3)
    np.testing.assert_array_equal(same.q, fast.q)  # the same run, whatever the layout of the feed-forward
    np.testing.assert_array_equal(same.joint_torque, fast.joint_torque)


def test_a_failing_trajectory_stops_alone_as_in_the_generic_kernel(specialised: Path) -> None:
    model = ff.models.papadopoulos1992()
    ff.mechanics.specialise(model, ["rollout"])
    n = model.n_joints
    t = tree(model)
    x0 = np.zeros((66, 13 + 2 * n))
    x0[:, 9] = 1.0
    feed = np.zeros((1, 66, n))
    feed[0, 3] = 1e200  # trajectory 3 overflows
    zero = np.zeros((66, n))
    args = (x0, 1e-3, 20, 1, 3, (zero, zero, zero, zero), feed, np.full(n + 6, np.inf))
    fast = _engine.rollout(model, *args)
    assert _specialise.find(t, "rollout") is not None
    with _specialise.generic():
        slow = _engine.rollout(model, *args)
    np.testing.assert_array_equal(fast[3], slow[3])
    assert fast[3][3] < 20 and (np.delete(fast[3], 3) == 20).all()
    np.testing.assert_array_equal(np.isnan(fast[0]), np.isnan(slow[0]))
    np.testing.assert_allclose(np.nan_to_num(fast[0]), np.nan_to_num(slow[0]), rtol=0, atol=1e-12)


def test_a_broken_cache_file_warns_and_is_rebuilt(specialised: Path) -> None:
    model = build_random_model(np.random.default_rng(12), [2], [None], [None])
    t = tree(model)
    ff.mechanics.specialise(model, ["jstar"])
    path = specialised / f"{_specialise.structure_key(t, 'jstar')}.py"
    path.write_text("def lane(W, P:\n")  # truncated
    _specialise._LOADED.clear()
    _specialise._FOUND.clear()
    with pytest.warns(CacheWarning, match="is broken"):
        assert not ff.mechanics.is_specialised(model, "jstar")  # the generic kernels serve meanwhile
    q = np.zeros((100, model.n_joints))
    np.testing.assert_allclose(ff.generalized_jacobian(model, q)[0], ff.generalized_jacobian(model, q[:1])[0])
    assert path.read_text() == "def lane(W, P:\n"  # a process that only reads never deletes the shared file
    with pytest.warns(CacheWarning, match="generating it again"):
        ff.mechanics.specialise(model, ["jstar"])  # rebuilt
    assert ff.mechanics.is_specialised(model, "jstar") and path.read_text().startswith('"""freefloat')


def test_unknown_kind_is_refused() -> None:
    with pytest.raises(ff.UnknownNameError, match="kind of specialised kernel"):
        ff.mechanics.specialise(ff.models.papadopoulos1992(), ["everything"])


def test_cli_specialise(specialised: Path) -> None:
    from typer.testing import CliRunner

    from freefloat.cli import app

    runner = CliRunner()
    result = runner.invoke(app, ["specialise", "papadopoulos1992", "--kind", "jstar"])
    assert result.exit_code == 0, result.output
    assert result.stdout.startswith("jstar: ready in ") and "specialising jstar" in result.stderr
    assert ff.mechanics.is_specialised(ff.models.papadopoulos1992(), "jstar")
    bad = runner.invoke(app, ["specialise", "papadopoulos1992", "--kind", "everything"])
    assert bad.exit_code == 1 and bad.stderr.startswith("error: ") and "kind of specialised kernel" in bad.stderr
    assert "Traceback" not in bad.output


def test_an_unwritable_cache_folder_warns_and_still_specialises(specialised: Path, tmp_path: Path) -> None:
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    _specialise.FOLDER[0] = blocker / "specialised"  # cannot be made: its parent is a file
    _specialise._LOADED.clear()
    _specialise._FOUND.clear()
    try:
        model = build_random_model(np.random.default_rng(13), [1, 1], [None, None], [None, None])
        with pytest.warns(CacheWarning, match="cannot write the specialised kernel"):
            ff.mechanics.specialise(model, ["jstar"])
        q = np.random.default_rng(1).uniform(-3, 3, (200, model.n_joints))
        fast = ff.generalized_jacobian(model, q)
        with _specialise.generic():
            slow = ff.generalized_jacobian(model, q)
        np.testing.assert_allclose(fast, slow, rtol=0, atol=1e-12)
    finally:
        _specialise.FOLDER[0] = None
        _specialise._LOADED.clear()
        _specialise._FOUND.clear()

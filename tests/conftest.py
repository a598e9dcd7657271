import os
import sys
from collections.abc import Iterator
from pathlib import Path

import matplotlib
import pytest
from hypothesis import settings

matplotlib.use("Agg")
# no background compiles in the suite's processes and the commands it starts (tests/mechanics/test_auto_specialise.py
# turns automatic specialisation on where it tests it)
os.environ["FREEFLOAT_AUTO_SPECIALISE"] = "0"
# ... and no background compile of this machine's kernels: a kernel not in the cache loads from the portable kernels
# freefloat ships (or compiles in the process that needs it); tests/engine/test_portable.py tests the other settings
os.environ.setdefault("FREEFLOAT_KERNELS", "portable")
sys.path.insert(0, str(Path(__file__).parent))

# The generic kernels compile into the user's cache folder, as in any use (keyed by numba's version and the engine's
# source, so a checkout never loads another's); every test that specialises or breaks a cache uses a temporary
# folder of its own (tests/mechanics/test_specialise.py, test_auto_specialise.py, test_specialise_dynamics.py,
# test_numba_cache.py).

#: The test files that take longest on a fresh clone (their kernels compile; a wheel installs), longest first, in
#: seconds of one worker on the 2-core VM, cold cache: they start first so that the workers of ``make test`` (pytest-xdist,
#: ``--dist loadfile --no-loadscope-reorder``) finish together instead of one of them running a long file alone at the end.
SLOWEST_FILES = (
    "tests/control/test_compiled.py",  # 155
    "tests/mechanics/test_specialise.py",  # 92
    "tests/test_release.py",  # 80
    "tests/mechanics/test_specialise_wrenches.py",  # 70
    "tests/simulation/test_rotors_and_passive.py",  # 57
    "tests/test_readme.py",  # 53
    "tests/campaigns/test_campaign_cluster.py",  # 40
    "tests/mechanics/test_measures.py",  # 33
    "tests/mechanics/test_numba_cache.py",  # 33
    "tests/mechanics/test_engine.py",  # 29
    "tests/mechanics/test_auto_specialise.py",  # 24
    "tests/mechanics/test_specialise_dynamics.py",  # 20
    "tests/mechanics/test_mimic.py",  # 19
    "tests/test_docs_site.py",  # 17
    "tests/oracle/test_pinocchio_core.py",  # 16
)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """The files of :data:`SLOWEST_FILES` first, in that order; the others after them, in the order collected."""
    root = Path(__file__).parent.parent
    gone = [name for name in SLOWEST_FILES if not (root / name).is_file()]
    if gone:
        raise pytest.UsageError(f"tests/conftest.py: SLOWEST_FILES names files that do not exist: {gone}")
    rank = {name: i for i, name in enumerate(SLOWEST_FILES)}
    items.sort(key=lambda item: rank.get(item.nodeid.split("::")[0], len(rank)))


settings.register_profile("freefloat", derandomize=True, deadline=None, print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "freefloat"))


@pytest.fixture(autouse=True, scope="session")
def _generic_kernels() -> Iterator[None]:
    """Tests run on the generic kernels even where this machine has specialised ones (``make bench`` makes
    some); ``tests/mechanics/test_specialise.py`` turns them on in a folder of its own."""
    from freefloat.engine.specialise import build as _specialise

    with _specialise.generic():
        yield


@pytest.fixture(autouse=True)
def _close_pyplot_figures() -> Iterator[None]:
    """Every ``plot()`` makes a pyplot figure (so scripts and notebooks show it); close them after each test."""
    yield
    if "matplotlib.pyplot" in sys.modules:
        sys.modules["matplotlib.pyplot"].close("all")

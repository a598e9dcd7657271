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
sys.path.insert(0, str(Path(__file__).parent))

# The generic kernels compile into the user's cache folder, as in any use (keyed by numba's version and the engine's
# source, so a checkout never loads another's); every test that specialises or breaks a cache uses a temporary
# folder of its own (tests/mechanics/test_specialise.py, test_auto_specialise.py, test_specialise_dynamics.py,
# test_numba_cache.py).

settings.register_profile("freefloat", derandomize=True, deadline=None, print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "freefloat"))


@pytest.fixture(autouse=True, scope="session")
def _generic_kernels() -> Iterator[None]:
    """Tests run on the generic kernels even where this machine has specialised ones (``make bench`` makes
    some); ``tests/mechanics/test_specialise.py`` turns them on in a folder of its own."""
    from freefloat.mechanics import _specialise

    with _specialise.generic():
        yield


@pytest.fixture(autouse=True)
def _close_pyplot_figures() -> Iterator[None]:
    """Every ``plot()`` makes a pyplot figure (so scripts and notebooks show it); close them after each test."""
    yield
    if "matplotlib.pyplot" in sys.modules:
        sys.modules["matplotlib.pyplot"].close("all")

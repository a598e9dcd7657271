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

#: The suite's own cache of compiled kernels (FREEFLOAT_CACHE_DIR), set before freefloat is imported, for this
#: process and the commands it starts: never the user's cache folder (~/.cache/freefloat). Kept in the checkout's
#: .pytest_cache (git-ignored, removed by make clean), so the kernels compile once per checkout, not per run;
#: tests of the cache itself and of the specialiser use temporary folders of their own.
SUITE_CACHE = Path(__file__).resolve().parents[1] / ".pytest_cache" / "freefloat"
os.environ["FREEFLOAT_CACHE_DIR"] = str(SUITE_CACHE)
assert "freefloat" not in sys.modules, "freefloat was imported before tests/conftest.py chose its kernel cache"

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

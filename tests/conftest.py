import os
import sys
from pathlib import Path

import matplotlib
from hypothesis import settings

matplotlib.use("Agg")
sys.path.insert(0, str(Path(__file__).parent))

settings.register_profile("freeflyer", derandomize=True, deadline=None, print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "freeflyer"))

"""Build the portable kernels freefloat ships: ``make kernels`` (after any change to the engine's kernel sources).

``python tools/portable_kernels.py`` runs the package's warm-up (``python -m freefloat.warmup``: the calls a new user
makes first) with ``NUMBA_CPU_NAME=generic`` (numba's portable target: code for any CPU of this target triple) into an
empty cache folder, then packs that folder's kernels into ``src/freefloat/engine/portable/kernels.tar.xz`` with their
manifest ``kernels.json`` (numba and Python versions, the engine source's key, the triple, the number of kernels,
their unpacked size, and the seconds each kernel took to compile: the estimates of a run that compiles quote them).
The files are replaced only when the build succeeded. Minutes: every kernel compiles.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TARGET = ROOT / "src" / "freefloat" / "engine" / "portable"


def build() -> dict[str, object]:
    with tempfile.TemporaryDirectory(prefix="freefloat-portable-") as folder:
        env = {
            **os.environ,
            "NUMBA_CPU_NAME": "generic",
            "FREEFLOAT_CACHE_DIR": folder,
            "FREEFLOAT_KERNELS": "native",  # compile every kernel (none loaded from an earlier build)
            "FREEFLOAT_AUTO_SPECIALISE": "0",  # specialised kernels are per robot structure: not shipped
            "FREEFLOAT_COMPILE_TIMES": str(Path(folder) / "compile-times.json"),  # each kernel's compile, for the estimates
        }
        start = time.perf_counter()
        subprocess.run([sys.executable, "-m", "freefloat.warmup"], check=True, env=env, cwd=ROOT)
        took = time.perf_counter() - start
        probe = (
            "import json, numba, sys; from llvmlite import binding; from freefloat.engine import cache_dir, source_key; "
            "print(json.dumps({'folder': str(cache_dir()), 'key': source_key(), 'numba': numba.__version__, "
            "'python': '%d.%d' % sys.version_info[:2], 'triple': binding.get_process_triple()}))"
        )
        facts = json.loads(subprocess.run([sys.executable, "-c", probe], check=True, env=env, capture_output=True, text=True).stdout)
        cache = Path(facts.pop("folder"))
        files = sorted(
            path for path in cache.rglob("*") if path.is_file() and path.suffix in (".nbi", ".nbc") and "specialised" not in path.parts
        )
        manifest = {
            **facts,
            "kernels": sum(1 for path in files if path.suffix == ".nbc"),
            "bytes": sum(path.stat().st_size for path in files),
            "build_seconds": round(took),
            "compile_seconds": json.loads((Path(folder) / "compile-times.json").read_text()),
        }
        TARGET.mkdir(parents=True, exist_ok=True)
        staging = TARGET / "kernels.tar.xz.new"
        with tarfile.open(staging, "w:xz", preset=9) as archive:
            for path in files:
                info = archive.gettarinfo(str(path), arcname=str(path.relative_to(cache)))
                info.mtime, info.uid, info.gid, info.uname, info.gname = 0, 0, 0, "", ""
                with path.open("rb") as file:
                    archive.addfile(info, file)
        staging.replace(TARGET / "kernels.tar.xz")
        (TARGET / "kernels.json").write_text(json.dumps(manifest, indent=2) + "\n")
        return manifest


if __name__ == "__main__":
    manifest = build()
    size = (TARGET / "kernels.tar.xz").stat().st_size
    print(
        f"portable kernels: {manifest['kernels']} kernels, {manifest['bytes'] / 1e6:.1f} MB ({size / 1e6:.1f} MB packed), "
        f"built in {manifest['build_seconds']} s, for numba {manifest['numba']}, Python {manifest['python']}, {manifest['triple']}"
    )

"""PNG files written by freefloat, read back: their pixel size and whether anything was drawn on them."""

from __future__ import annotations

from pathlib import Path

import matplotlib.image as mpimg
import numpy as np


def read_png(path: Path) -> np.ndarray:
    """The pixels of a PNG file, (height, width, channels) floats in [0, 1]; fails on a file that is not a PNG."""
    data = Path(path).read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", f"{path} is not a PNG file"
    pixels = mpimg.imread(path, format="png")
    assert pixels.ndim == 3 and pixels.shape[2] in (3, 4), pixels.shape
    return pixels


def check_png(path: Path, figsize: tuple[float, float], dpi: float, *, tight: bool = False, min_colours: int = 8) -> np.ndarray:
    """A figure saved as ``path`` at ``dpi``: its pixel size and that something was drawn. Returns the pixels.

    Without ``tight`` the image is figsize x dpi pixels (to the pixel). With ``tight`` (``bbox_inches="tight"``)
    it is cropped or grown to what was drawn plus the padding (a legend outside the axes grows it): each side
    within 0.6-1.5 times the figure's, so a wrong dpi is found. Drawn: at least ``min_colours`` distinct colours
    and 2 % of the pixels not the background (an empty figure is one colour).
    """
    pixels = read_png(path)
    height, width = pixels.shape[:2]
    full_w, full_h = figsize[0] * dpi, figsize[1] * dpi
    if tight:
        assert 0.6 * full_w <= width <= 1.5 * full_w and 0.6 * full_h <= height <= 1.5 * full_h, (path, width, height, full_w, full_h)
    else:
        assert abs(width - full_w) < 1.0 and abs(height - full_h) < 1.0, (path, width, height, full_w, full_h)
    rgb = (pixels[..., :3] * 255.0 + 0.5).astype(np.uint32).reshape(-1, 3)
    _, counts = np.unique((rgb[:, 0] << 16) | (rgb[:, 1] << 8) | rgb[:, 2], return_counts=True)  # pixels per colour
    assert len(counts) >= min_colours, (path, len(counts))
    assert 1.0 - counts.max() / counts.sum() > 0.02, f"{path}: {counts.max() / counts.sum():.1%} of the pixels are one colour"
    return pixels


#: The papers' figures as ``freefloat reproduce`` and ``freefloat demo`` save them: name -> (figsize in inches, dpi,
#: saved with bbox_inches="tight"). From freefloat/papers/paper1991_figures.py and paper1992_figures.py.
PAPER_FIGURES: dict[str, tuple[tuple[float, float], int, bool]] = {
    "fig3_coordinated_motion.png": ((11.0, 5.2), 150, False),
    "fig4_spacecraft_errors.png": ((9.0, 6.0), 150, False),
    "fig5_thruster_forces.png": ((10.0, 9.6), 150, False),
    "fig_alternatives.png": ((13.0, 4.8), 150, False),
    "fig4_two_arm_workspaces.png": ((12.0, 7.4), 200, True),
    "fig6_capture_families.png": ((8.0, 5.0), 200, True),
    "fig7_capture_plan.png": ((7.4, 8.4), 200, True),
    "fig_singularity_maps.png": ((12.0, 8.4), 200, True),
}


def check_paper_figure(path: Path) -> np.ndarray:
    """:func:`check_png` for one of the papers' figures, by its file name (:data:`PAPER_FIGURES`)."""
    figsize, dpi, tight = PAPER_FIGURES[Path(path).name]
    return check_png(path, figsize, dpi, tight=tight, min_colours=64)

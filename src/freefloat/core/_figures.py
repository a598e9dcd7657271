"""Figures that scripts and notebooks display (private helpers of every ``.plot``).

A figure that a ``plot()`` call hands to the user is made with pyplot
(``plt.figure``), so ``plt.show()`` and a notebook cell display it. Code that
only writes files draws on such a figure too and closes it when saved
(:func:`save_and_close`), so nothing accumulates in pyplot's registry.
matplotlib is imported only when a figure is made.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["new_axes", "new_figure", "save_and_close"]


def new_figure(**kw: Any) -> Figure:
    """A new pyplot-managed figure (``plt.figure``), constrained layout unless ``layout`` is given."""
    import matplotlib.pyplot as plt

    kw.setdefault("layout", "constrained")
    return plt.figure(**kw)


def new_axes(*, projection: str | None = None, **kw: Any) -> Axes:
    """One axes on a new pyplot-managed figure (``projection="3d"`` for mpl_toolkits.mplot3d axes)."""
    return new_figure(**kw).add_subplot(projection=projection)


def save_and_close(fig: Figure, path: str | Path, **kw: Any) -> Path:
    """``fig.savefig(path, **kw)``, then close the figure (pyplot forgets it); returns the path."""
    import matplotlib.pyplot as plt

    fig.savefig(path, **kw)
    plt.close(fig)
    return Path(path)

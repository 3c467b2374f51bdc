"""sightline: which triangles of a 3D scene can be seen?

Scenes (loaded from a file or procedural spec, or built from numpy arrays), view cells, PVS
bakes of one cell or many (GVS++, GVS, RAND, RASTER), ``.pvs`` files, exact / conservative
from-point visibility, and the HTML report of a ``.pvs`` file (``report``, as ``sightline
report``). Triangle ids go in and out as numpy ``uint32`` arrays.

Results equal the ``sightline`` CLI's: ``bake(scene, cells, method, rays=R, seed=S)`` gives the
same cells and sets as ``sightline pvs bake SCENE ... --rays R --seed S``, because every cell's
seed is ``cell_seed(S, index_of_the_cell)`` in both.

``sightline.ray.bake`` runs the same bake as Ray tasks (``pip install ray``).

Long bakes (``bake``, ``bake_cells``, ``sightline.ray.bake``) show their progress on stderr
when it is a terminal (``progress=False`` turns it off; a callable receives ``(cells_done,
cells_total, rays)``, see ``sightline._progress``) and stop on Ctrl-C with
``KeyboardInterrupt`` (cells under way finish first). Thread counts far above the machine's
cores are capped with a ``RuntimeWarning``. Paths may be ``str`` or ``os.PathLike``.

Errors: ``ValueError`` for bad input (the message names what and where), ``OSError`` for files
that cannot be read or written.
"""

import os
from typing import Union

from ._sightline import (
    METHODS,
    Method,
    Pvs,
    Scene,
    ViewCell,
    __version__,
    bake,
    bake_cell,
    bake_cells,
    bake_q3,
    cell_seed,
    evaluate,
    grid,
    report,
    visible_conservative,
    visible_exact,
)

__all__ = [
    "METHODS",
    "Method",
    "Pvs",
    "Scene",
    "ViewCell",
    "__version__",
    "bake",
    "bake_cell",
    "bake_cells",
    "bake_q3",
    "cell_seed",
    "evaluate",
    "grid",
    "load",
    "report",
    "visible_conservative",
    "visible_exact",
]


def load(spec: Union[str, "os.PathLike[str]"], patch_subdivisions: int = 4) -> Scene:
    """Loads a scene file or procedural spec (``Scene.load``): a ``str`` is a path or
    ``procedural:...`` spec, an ``os.PathLike`` (e.g. ``pathlib.Path``) a file."""
    return Scene.load(spec, patch_subdivisions)

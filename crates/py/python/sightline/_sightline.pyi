"""Type stubs of the native module (see the Rust sources in crates/py/src for the docs)."""

from os import PathLike
from typing import Any, Callable, Dict, Iterator, List, Literal, Optional, Sequence, Tuple, Union, overload

import numpy as np
import numpy.typing as npt

METHODS: List[str]
__version__: str

_Vec3 = Union[Sequence[float], npt.NDArray[np.floating]]
_Ids = npt.NDArray[np.uint32]

class Scene:
    @staticmethod
    def load(spec: Union[str, PathLike], patch_subdivisions: int = 4) -> Scene: ...
    @staticmethod
    def from_arrays(
        vertices: npt.ArrayLike, triangles: npt.ArrayLike, source: str = "arrays", up: str = "z"
    ) -> Scene: ...
    @property
    def triangle_count(self) -> int: ...
    @property
    def vertex_count(self) -> int: ...
    @property
    def vertices(self) -> npt.NDArray[np.float32]: ...
    @property
    def triangles(self) -> npt.NDArray[np.uint32]: ...
    @property
    def bounds(self) -> Tuple[npt.NDArray[np.float32], npt.NDArray[np.float32]]: ...
    @property
    def geometry_hash(self) -> int: ...
    @property
    def source(self) -> str: ...
    @property
    def up(self) -> str: ...
    def __len__(self) -> int: ...

class ViewCell:
    def __init__(
        self, center: _Vec3, axes: Sequence[_Vec3], half_extents: _Vec3
    ) -> None: ...
    @staticmethod
    def box(min: _Vec3, max: _Vec3) -> ViewCell: ...
    @staticmethod
    def parse(spec: str) -> ViewCell: ...
    @property
    def center(self) -> npt.NDArray[np.float32]: ...
    @property
    def axes(self) -> Tuple[Tuple[float, float, float], ...]: ...
    @property
    def half_extents(self) -> npt.NDArray[np.float32]: ...
    @property
    def is_flat(self) -> bool: ...
    def contains(self, point: _Vec3) -> bool: ...

class Method:
    def __init__(
        self,
        name: str = "gvs++",
        *,
        n_rand: Optional[int] = None,
        n_abs_edge: Optional[int] = None,
        delta_abs: Optional[float] = None,
        n_rs_edge: Optional[int] = None,
        n_rs_area: Optional[int] = None,
        delta: Optional[float] = None,
        termination: Optional[int] = None,
        raster_resolution: Optional[int] = None,
        fixed_rounds: bool = False,
        paper_discontinuities: bool = False,
    ) -> None: ...
    @property
    def name(self) -> str: ...

class Pvs:
    def __init__(
        self,
        scene: Scene,
        cells: Sequence[ViewCell],
        sets: Sequence[npt.ArrayLike],
        metadata: Any = None,
        bounds: Optional[Sequence[npt.ArrayLike]] = None,
    ) -> None: ...
    @staticmethod
    def load(path: Union[str, PathLike]) -> Pvs: ...
    @staticmethod
    def from_bytes(data: bytes) -> Pvs: ...
    def save(self, path: Union[str, PathLike]) -> None: ...
    def to_bytes(self) -> bytes: ...
    def check_scene(self, scene: Scene) -> None: ...
    @property
    def scene_hash(self) -> int: ...
    @property
    def triangle_count(self) -> int: ...
    @property
    def metadata(self) -> Any: ...
    @property
    def cells(self) -> List[ViewCell]: ...
    def visible(self, i: int) -> _Ids: ...
    def sets(self) -> List[_Ids]: ...
    @property
    def has_bounds(self) -> bool: ...
    def bound(self, i: int) -> _Ids: ...
    @property
    def object_count(self) -> int: ...
    @property
    def object_names(self) -> List[str]: ...
    def object_of_triangle(self) -> _Ids: ...
    def object_ranges(self) -> npt.NDArray[np.uint32]: ...
    def object_bounds(
        self,
    ) -> Tuple[npt.NDArray[np.float32], npt.NDArray[np.float32]]: ...
    def visible_objects(self, i: int) -> _Ids: ...
    def object_sets(self) -> List[_Ids]: ...
    def __len__(self) -> int: ...
    def __getitem__(self, i: int) -> _Ids: ...
    def __iter__(self) -> Iterator[_Ids]: ...

_MethodArg = Union[str, Method]
# None: a line on stderr when it is a terminal; False: none; True: always that line; a callable
# is called as progress(cells_done, cells_total, rays) (see sightline._progress).
_Progress = Union[None, bool, Callable[[int, int, int], object]]

def grid(min: _Vec3, max: _Vec3, counts: Tuple[int, int, int]) -> List[ViewCell]: ...
def cell_seed(seed: int, index: int) -> int: ...
def bake_cell(
    scene: Scene,
    cell: ViewCell,
    method: _MethodArg = "gvs++",
    rays: Optional[int] = None,
    seed: int = 1,
    index: int = 0,
    time_ms: Optional[int] = None,
    threads: Optional[int] = None,
    progress: _Progress = None,
) -> _Ids: ...
@overload
def bake_cells(
    scene: Scene,
    cells: Sequence[ViewCell],
    method: _MethodArg = "gvs++",
    rays: Optional[int] = None,
    seed: int = 1,
    indices: Optional[Sequence[int]] = None,
    time_ms: Optional[int] = None,
    threads: Optional[int] = None,
    progress: _Progress = None,
    stats: Literal[False] = False,
) -> List[_Ids]: ...
@overload
def bake_cells(
    scene: Scene,
    cells: Sequence[ViewCell],
    method: _MethodArg = "gvs++",
    rays: Optional[int] = None,
    seed: int = 1,
    indices: Optional[Sequence[int]] = None,
    time_ms: Optional[int] = None,
    threads: Optional[int] = None,
    progress: _Progress = None,
    *,
    stats: Literal[True],
) -> Tuple[List[_Ids], List[Dict[str, Any]]]: ...
def bake(
    scene: Scene,
    cells: Sequence[ViewCell],
    method: _MethodArg = "gvs++",
    rays: Optional[int] = None,
    seed: int = 1,
    time_ms: Optional[int] = None,
    threads: Optional[int] = None,
    progress: _Progress = None,
    *,
    since: Optional[Pvs] = None,
    old_scene: Optional[Scene] = None,
    probe_rays: int = 16384,
    device: Literal["cpu", "gpu"] = "cpu",
    gpu_caster: Literal["auto", "compute", "ray-query"] = "auto",
    bound: bool = False,
    bound_occluders: int = 4096,
    bound_fusion_splits: int = 0,
    bound_solid_fusion: Union[float, Literal["auto", "off"], None] = None,
) -> Pvs:
    """Bakes ``cells`` on this machine as ``sightline pvs bake`` does (same cells, sets and
    per-cell statistics). As the CLI's default, ray origins skip the parts of a cell that lie
    inside closed geometry (8x8x8 voxels a cell; ``pvs bake --help``, ``--origins-anywhere``).

    ``device="gpu"`` casts the rays on the GPU, as ``pvs bake --device gpu --gpu-caster C``
    (16 cells at once, their ray batches cast together). ``gpu_caster="auto"`` takes hardware
    ray queries where the adapter has them, else the compute caster. ``"compute"`` gives the same
    sets as on the CPU for the same seed and rays where the adapter has ``SHADER_F64`` (lavapipe,
    NVIDIA, AMD; else a ``RuntimeWarning``); ``"ray-query"`` uses the driver's triangle test, so
    a set may differ where a ray decides at a tie or an edge within rounding. ``RuntimeError`` when there is no Vulkan adapter or the package was
    built without the cargo feature ``gpu``; ``ValueError`` for another device name.

    Incremental rebake (``pvs bake --since OLD.pvs --old-scene OLD --probe-rays N``): with
    ``since`` (an earlier bake of the same cells, method, parameters, seed and budget, by the
    CLI, the Ray driver or this function) and ``old_scene`` (the scene it was baked for), the cells the edit
    from ``old_scene`` to ``scene`` cannot change keep their sets from ``since`` and only the
    others are baked; ``probe_rays`` as ``--probe-rays`` (its default; 0 skips the probe).

    ``bound=True`` is ``pvs bake --bound``: every cell also gets a conservative bound, RV's
    from-region set joined with the sampled set (``Pvs.bound(i)``), so the file says per
    cell what is surely visible and what might be; ``metadata["cells"][i]["gap"]`` counts
    the triangles between the two. ``bound_occluders`` and ``bound_fusion_splits`` are
    ``--bound-occluders`` and ``--bound-fusion-splits``: more occluders and levels of
    occluder fusion give a tighter bound for more time (``ValueError`` out of range).
    ``bound_solid_fusion`` is ``--bound-solid-fusion``: ``"auto"`` or a radius (scene units)
    also leaves out what the union of the scene's closed solids, shrunk by it, hides from a
    grid of viewpoints of the cell (blocks of houses hiding together; 11-35x the bound's time
    on the shared city cells); ``None`` or ``"off"``: not.
    Pass both or neither. The result equals the CLI's, and ``metadata["incremental"]`` counts
    the ``kept_cells`` and ``rebaked_cells``. A ``since`` that cannot serve (baked
    differently, a shard, without a fingerprint, or for another scene than ``old_scene``)
    raises ``ValueError`` with the reason.
    """
    ...

def bake_q3(
    scene: Scene,
    cells: Literal["leaves", "clusters"] = "leaves",
    method: _MethodArg = "gvs++",
    rays: Optional[int] = None,
    seed: int = 1,
    time_ms: Optional[int] = None,
    threads: Optional[int] = None,
    progress: _Progress = None,
    *,
    clusters: Optional[Sequence[int]] = None,
    include_unreachable: bool = False,
    reach_step: float = 16.0,
) -> Pvs: ...
def _bake_fingerprint(
    scene: Scene, cells: Sequence[ViewCell], method: _MethodArg, rays: Optional[int], seed: int
) -> str: ...
def visible_exact(
    scene: Scene,
    eye: _Vec3,
    look: _Vec3,
    up: Optional[_Vec3] = None,
    fov: float = 60.0,
    size: Tuple[int, int] = (1024, 768),
    near: Optional[float] = None,
    bin_size: int = 16,
) -> _Ids: ...
def visible_conservative(
    scene: Scene,
    eye: _Vec3,
    look: _Vec3,
    up: Optional[_Vec3] = None,
    fov: float = 60.0,
    size: Tuple[int, int] = (1024, 768),
    near: Optional[float] = None,
    memory: int = 268435456,
    guarantee: str = "area",
) -> _Ids: ...
def evaluate(
    scene: Scene,
    pvs: Pvs,
    views: int = 16,
    size: int = 256,
    view_mode: Literal["cube", "random"] = "cube",
    seed: int = 1,
    cells: Optional[Sequence[int]] = None,
) -> List[Dict[str, Any]]:
    """The pixel error of ``pvs`` per cell, as ``sightline eval SCENE PVS --json`` measures it:
    one dict per cell (``cell``, ``pvs_size``, ``avg_error_pixels``, ``max_error_pixels``,
    ``false_negatives``, ..., ``rejected_viewpoints``). Raises ``ValueError`` for bad
    arguments, a missing cell or a ``pvs`` of another scene."""
    ...

def report(
    scene: Scene,
    pvs: Pvs,
    out_dir: Union[str, PathLike],
    views: int = 16,
    size: int = 256,
    view_mode: Literal["cube", "random"] = "cube",
    worst: int = 6,
    seed: int = 1,
    budgets: Optional[Sequence[int]] = [250000, 1000000],
    budget_cells: int = 4,
    cell_rows: int = 20,
) -> Dict[str, Any]:
    """Writes the HTML report of ``pvs`` (baked for ``scene``) to ``out_dir/index.html``, as
    ``sightline report SCENE PVS -o OUT_DIR`` does: summary, a map of the cells (coloured by PVS
    size or pixel error), the worst views, per-cell PVS size and pixel error (the ``cell_rows``
    worst cells shown, the rest behind a toggle and a filter), convergence plots, GVS++ against
    RAND at equal budgets.

    ``views`` viewpoints per cell, ``size`` x ``size`` pixel images (1 to 4096), ``view_mode``
    ``"cube"`` (six faces per viewpoint) or ``"random"`` (one 90-degree view), ``worst`` worst
    views shown, ``seed`` of the viewpoints and of the comparison's bakes. ``budgets``: ray
    budgets per cell (1 to 8, increasing) of the GVS++ / RAND comparison on ``budget_cells``
    cells; ``None`` or ``[]`` leaves it out.

    Returns the CLI's ``--json`` summary: ``{"report": path, "scene": source, "cells": [{"cell",
    "pvs_size", "avg_error_pixels", "max_error_pixels", "avg_unconfirmed_pixels",
    "false_negatives", "rejected_viewpoints"}, ...], "budgets": {"cells": [...], "points":
    [{"method", "budget", "rays", "seconds", "avg_error_pixels"}, ...]} or None}``.

    Raises ``ValueError`` for bad arguments, a ``pvs`` of another scene, or an output that is
    the scene or ``.pvs`` file; ``OSError`` when the report cannot be written. The GIL is
    released while it works.
    """
    ...

"""Mesh simplification and level of detail on numpy arrays.

The Rust library ``meshlod`` as a Python package: every function takes and returns
numpy arrays (``vertices`` of shape ``(n, 3)``, ``faces`` of shape ``(m, 3)``), so it
fits trimesh, Open3D and plain numpy code::

    import meshlod, trimesh
    m = trimesh.load("bunny.obj")
    small = trimesh.Trimesh(*meshlod.simplify(m.vertices, m.faces, ratio=0.1)[:2])

Inputs: ``vertices`` float32 or float64, ``faces`` any integer dtype (int32, int64,
uint32, ...), any memory layout (C order is read as one block, other layouts through
their strides). Outputs come back in the inputs' dtypes. The library computes in
float32 positions (``float64`` input is rounded once, output widened back).

Errors: a wrong dtype is a ``TypeError``; a wrong shape, a negative or out-of-range
index, a NaN or infinite coordinate, or a bad option is a ``ValueError`` with the
library's message; a missing file is a ``FileNotFoundError``. The GIL is released
while the library works, and ``threads=`` caps the threads it uses.

Reports are ``dict``s with the field names of the command-line tool's ``--json``
output (``meshlod simplify --json``, ``meshlod measure --json``, ...).
"""

from __future__ import annotations

import os
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _meshlod

__all__ = [
    "simplify",
    "Simplified",
    "measure",
    "read",
    "write",
    "lod",
    "terrain",
    "__version__",
]

__version__: str = _meshlod.__version__

PathLike = Union[str, "os.PathLike[str]"]


class Simplified(tuple):
    """The result of :func:`simplify`: a 3-tuple ``(vertices, faces, report)``.

    Unpacks as ``v, f, report = meshlod.simplify(...)``; two more results are
    attributes:

    - ``attributes``: ``dict`` of the output's ``normals``, ``uvs`` and ``colors``
      (the ones given), in the dtypes they were given in;
    - ``vertex_source``: for every output vertex the input vertex it descends from
      (its attributes were interpolated where it moved), in the faces' dtype; empty
      for ``method="cluster"`` without attributes.
    """

    attributes: Dict[str, np.ndarray]
    vertex_source: np.ndarray

    def __new__(
        cls,
        vertices: np.ndarray,
        faces: np.ndarray,
        report: Dict[str, Any],
        attributes: Dict[str, np.ndarray],
        vertex_source: np.ndarray,
    ) -> "Simplified":
        self = super().__new__(cls, (vertices, faces, report))
        self.attributes = attributes
        self.vertex_source = vertex_source
        return self

    @property
    def vertices(self) -> np.ndarray:
        """The output vertices, shape ``(n, 3)``."""
        return self[0]

    @property
    def faces(self) -> np.ndarray:
        """The output triangles, shape ``(m, 3)``."""
        return self[1]

    @property
    def report(self) -> Dict[str, Any]:
        """What happened (the fields of ``meshlod simplify --json``)."""
        return self[2]


def _array(a: Any) -> Any:
    """``a`` as a numpy array without a copy when it is one (trimesh's
    ``TrackedArray``, Open3D's ``np.asarray(mesh.vertices)``); lists are converted."""
    return a if a is None or isinstance(a, np.ndarray) else np.asarray(a)


def simplify(
    vertices: np.ndarray,
    faces: np.ndarray,
    *,
    ratio: Optional[float] = None,
    triangles: Optional[int] = None,
    max_error: Optional[float] = None,
    absolute: bool = False,
    method: str = "qem",
    lock_boundary: bool = False,
    locked: Optional[np.ndarray] = None,
    fit: bool = False,
    swap: bool = False,
    measure: bool = False,
    threads: Optional[int] = None,
    normals: Optional[np.ndarray] = None,
    uvs: Optional[np.ndarray] = None,
    colors: Optional[np.ndarray] = None,
    free_topology: bool = False,
    permissive: bool = False,
    strict_seams: bool = False,
) -> Simplified:
    """Simplify a triangle mesh; returns ``(vertices, faces, report)``.

    The same run as ``meshlod simplify`` on a file holding these arrays: same
    options, same output, same report fields.

    Args:
        vertices: ``(n, 3)`` float32 or float64 positions.
        faces: ``(m, 3)`` integer vertex indices (counter-clockwise seen from the
            front).
        ratio: keep this fraction of the triangles, in ``[0, 1]``. With neither
            ``ratio``, ``triangles`` nor ``max_error`` the target is 0.5.
        triangles: target triangle count (with ``ratio`` too, the larger count).
        max_error: stop before a collapse whose error exceeds this distance, a
            fraction of the bounding-box diagonal (mesh units with ``absolute``).
        absolute: read ``max_error`` and report ``error`` in mesh units.
        method: ``"qem"`` (quadric error metric edge collapse, default),
            ``"melax"`` (half-edge collapses, no vertex moves), ``"vertex-removal"``
            (Schroeder decimation: output vertices are input vertices) or
            ``"cluster"`` (vertex clustering, O(n), may change the topology).
        lock_boundary: never move or remove a boundary vertex.
        locked: ``(n,)`` bool mask of vertices never moved or removed.
        fit: QEM: after simplifying, swap diagonals and move points toward the
            input (lower Hausdorff distance, 1.8-2.8x the time).
        swap: QEM: after simplifying, swap diagonals toward the input.
        measure: also measure the symmetric Hausdorff distance to the input
            (report ``hausdorff``, in the units of ``error``, and ``measure``).
        threads: at most this many threads (default: all cores).
        normals: ``(n, 3)`` float per-vertex normals, carried to the output.
        uvs: ``(n, 2)`` float texture coordinates, carried to the output.
        colors: ``(n, 3)`` or ``(n, 4)`` colours, floats in ``[0, 1]`` or uint8.
        free_topology: QEM, Melax: let holes of three edges close, separate
            parts be removed whole and points where parts touch slide, where that
            reaches the target (report ``holes_closed``,
            ``components_removed``); as ``--free-topology``.
        permissive: QEM: cross texture seams and material borders at their
            attribute cost, like any other collapse (by default a seam is
            crossed only where keeping it costs ten times more); as
            ``--permissive``.
        strict_seams: QEM: never cross a seam (a mesh cut by many seams may
            stop above its target); as ``--strict-seams``. Not with
            ``permissive``.

    Returns:
        :class:`Simplified`: ``(vertices, faces, report)`` in the inputs' dtypes,
        with ``.attributes`` (the output's normals, uvs, colors) and
        ``.vertex_source``. ``report`` has the fields of
        ``meshlod simplify --json``: ``triangles_in``, ``triangles_out``,
        ``vertices_out``, ``target_triangles``, ``error`` (quadric estimate),
        ``stop_reason``, ``stop_detail``, ``seconds``, ``phase_seconds``, ...

    Raises:
        TypeError: an argument is not an array, or has the wrong dtype.
        ValueError: a wrong shape, an index that is negative or not below ``n``, a
            NaN or infinite coordinate, an attribute without one row per vertex,
            or an option out of range.
    """
    locked_mask = None if locked is None else np.asarray(locked, dtype=bool)
    v, f, report, attributes, sources = _meshlod.simplify(
        _array(vertices),
        _array(faces),
        ratio=ratio,
        triangles=triangles,
        max_error=max_error,
        absolute=absolute,
        method=method,
        lock_boundary=lock_boundary,
        locked=locked_mask,
        fit=fit,
        swap=swap,
        measure=measure,
        threads=threads,
        normals=_array(normals),
        uvs=_array(uvs),
        colors=_array(colors),
        free_topology=free_topology,
        permissive=permissive,
        strict_seams=strict_seams,
    )
    return Simplified(v, f, report, attributes, sources)


def measure(
    a_vertices: np.ndarray,
    a_faces: np.ndarray,
    b_vertices: np.ndarray,
    b_faces: np.ndarray,
    *,
    samples: Optional[int] = None,
    seed: int = 0,
    threads: Optional[int] = None,
    certify: bool = True,
    appearance: bool = True,
    a_attributes: Optional[Dict[str, np.ndarray]] = None,
    b_attributes: Optional[Dict[str, np.ndarray]] = None,
) -> Dict[str, Any]:
    """Metro-class distances between surface A (the reference) and surface B.

    Samples every vertex, points along edges by length and on faces by area of each
    mesh, and finds each sample's exact closest point on the other (both
    directions); deterministic for a given ``seed``. The same numbers as
    ``meshlod measure A B --json``.

    Args:
        a_vertices, a_faces: the reference mesh (relative values are fractions of
            its bounding-box diagonal).
        b_vertices, b_faces: the mesh compared with it.
        samples: about this many samples on edges and as many on faces, per
            direction, besides every vertex (MeshLab's ``samplenum``). Default
            ``max(1_000_000, 10 * triangles)``.
        seed: seed of the face samples' placement.
        threads: at most this many threads (default: all cores).
        certify: refine after sampling so that the true maximum lies in
            ``[max_lower, max_upper]`` (``--no-certify`` of the CLI is ``False``:
            ``max_upper`` is then ``None``).
        appearance: also measure the attribute deviation (UV distance, normal
            angle in degrees, colour difference) where both meshes carry the
            attribute (``--no-appearance`` of the CLI is ``False``).
        a_attributes, b_attributes: each mesh's ``normals``, ``uvs``, ``colors``
            (a ``dict`` as :func:`read` returns; the keys optional).

    Returns:
        ``dict`` with ``hausdorff``, ``max_lower``, ``max_upper``, ``mean``,
        ``rms`` (mesh units), ``a_to_b`` and ``b_to_a`` (each ``max``,
        ``max_lower``, ``max_upper``, ``mean``, ``rms``, ``max_at``,
        ``max_closest``, ``samples``), ``relative_to_bbox_diagonal``,
        ``relative_to_max_extent``, ``bbox_diagonal``, ``max_extent``,
        ``samples``, ``seconds``; with attributes on both sides, ``appearance``
        (``uv``, ``normal_deg``, ``color``: ``max`` and ``mean``; ``a_to_b``,
        ``b_to_a``) and ``appearance_seconds``, as ``meshlod measure --json``.

    Raises:
        TypeError, ValueError: as :func:`simplify`; also a mesh without triangles.
    """
    aa = a_attributes or {}
    ba = b_attributes or {}
    unknown = (set(aa) | set(ba)) - {"normals", "uvs", "colors"}
    if unknown:
        raise ValueError(f"unknown attribute(s) {sorted(unknown)}: normals, uvs, colors")
    return _meshlod.measure(
        _array(a_vertices),
        _array(a_faces),
        _array(b_vertices),
        _array(b_faces),
        samples=samples,
        seed=seed,
        threads=threads,
        certify=certify,
        appearance=appearance,
        a_normals=_array(aa.get("normals")),
        a_uvs=_array(aa.get("uvs")),
        a_colors=_array(aa.get("colors")),
        b_normals=_array(ba.get("normals")),
        b_uvs=_array(ba.get("uvs")),
        b_colors=_array(ba.get("colors")),
    )


def read(path: PathLike) -> Tuple[np.ndarray, np.ndarray, Dict[str, np.ndarray]]:
    """Read a mesh file: ``(vertices, faces, attributes)``.

    OBJ, PLY, STL, OFF, glTF/GLB and Hoppe ``.m``, by extension. A scene (several
    objects, glTF nodes) is flattened into one mesh in world space, as the CLI
    reads it.

    Returns:
        ``vertices`` float32 ``(n, 3)``, ``faces`` int32 ``(m, 3)`` and a ``dict``
        of the attributes the file has: ``normals`` ``(n, 3)``, ``uvs`` ``(n, 2)``
        and ``colors`` ``(n, 4)``, float32 (colours in ``[0, 1]``). So
        ``meshlod.write(out, *meshlod.read(path)[:2], **meshlod.read(path)[2])``
        copies a file.

    Raises:
        FileNotFoundError: no such file.
        ValueError: unknown extension, a malformed file (with the line, byte or
            element) or an invalid mesh.
    """
    return _meshlod.read(os.fspath(path))


def write(
    path: PathLike,
    vertices: np.ndarray,
    faces: np.ndarray,
    *,
    normals: Optional[np.ndarray] = None,
    uvs: Optional[np.ndarray] = None,
    colors: Optional[np.ndarray] = None,
    ascii: bool = False,
) -> None:
    """Write a mesh file, the format by the extension.

    Args:
        path: ``.obj``, ``.ply``, ``.stl``, ``.off``, ``.gltf``, ``.glb`` or ``.m``.
        vertices, faces: as :func:`simplify` takes them.
        normals, uvs, colors: optional per-vertex attributes, as :func:`simplify`
            takes them (written where the format holds them; STL holds none).
        ascii: text PLY or STL instead of binary.

    Raises:
        TypeError, ValueError: as :func:`simplify`; an unknown extension.
        OSError: the file cannot be written.
    """
    _meshlod.write(
        os.fspath(path),
        _array(vertices),
        _array(faces),
        normals=_array(normals),
        uvs=_array(uvs),
        colors=_array(colors),
        ascii=ascii,
    )


def lod(
    vertices: np.ndarray,
    faces: np.ndarray,
    *,
    levels: Optional[int] = None,
    ratios: Optional[Sequence[float]] = None,
    method: str = "qem",
    pixel_error: float = 1.0,
    screen_height: float = 1080.0,
    fov: float = 60.0,
    samples: Optional[int] = None,
    threads: Optional[int] = None,
) -> Tuple[List[Tuple[np.ndarray, np.ndarray]], Dict[str, Any]]:
    """Build a level-of-detail chain: ``(levels, report)``.

    LOD0 is the input; each coarser level is simplified from the one before and
    measured against LOD0 (two-sided Hausdorff), with the camera distance from
    which its error covers at most ``pixel_error`` pixels (as ``meshlod lod``).

    Args:
        vertices, faces: as :func:`simplify` takes them.
        levels: this many levels after LOD0 chosen by error, each about twice the
            previous level's error and at most half its triangles (default 4).
        ratios: instead, one level per fraction of LOD0's triangles, strictly
            decreasing in ``(0, 1)``.
        method: as :func:`simplify`.
        pixel_error, screen_height, fov: the screen the switch distances are for
            (pixels, pixels, vertical degrees).
        samples: samples per direction of each level's measurement (default 10 per
            triangle of the sampled mesh, at least 20,000, at most 2,000,000).
        threads: at most this many threads (default: all cores).

    Returns:
        ``levels``: a list of ``(vertices, faces)``, LOD0 first, in the inputs'
        dtypes; ``report``: ``levels`` (each ``level``, ``triangles``,
        ``vertices``, ``error_max``, ``error_mean``, ``switch_distance``,
        ``screen_coverage``, ``seconds``), ``center``, ``radius``,
        ``cull_coverage``, ``stopped_early`` (when fewer levels than asked),
        ``simplify_seconds``, ``measure_seconds``.

    Raises:
        TypeError, ValueError: as :func:`simplify`; ratios not strictly decreasing
        in ``(0, 1)``, a bad screen.
    """
    return _meshlod.lod(
        _array(vertices),
        _array(faces),
        levels=levels,
        ratios=None if ratios is None else [float(r) for r in ratios],
        method=method,
        pixel_error=pixel_error,
        screen_height=screen_height,
        fov=fov,
        samples=samples,
        threads=threads,
    )


def terrain(
    heights: Union[np.ndarray, PathLike],
    *,
    max_error: Optional[float] = None,
    triangles: Optional[int] = None,
    z_scale: float = 1.0,
    cell_size: Optional[float] = None,
    block_size: int = 257,
    prune: bool = True,
    threads: Optional[int] = None,
) -> Tuple[np.ndarray, np.ndarray, Dict[str, Any]]:
    """Triangulate a height field within a vertical error bound (a TIN).

    Greedy insertion with Delaunay updates (Garland & Heckbert 1995) in crack-free
    blocks, then removal of the vertices no longer needed; every grid sample ends
    within ``max_error`` of the surface, vertically (as ``meshlod terrain``).

    Args:
        heights: a 2-D float32/float64 array (rows, columns; NaN marks a void,
            filled from its neighbours) or the path of a greyscale PNG, SRTM
            ``.hgt``, ESRI ``.asc`` or GeoTIFF file.
        max_error: the vertical bound, in height units after ``z_scale``. Default
            1 unless ``triangles`` is given.
        triangles: stop once the TIN has this many triangles (or the bound holds).
        z_scale: multiply every height by this.
        cell_size: distance between neighbouring samples in x and y (default: the
            file's cell size for ``.asc`` and GeoTIFF, else 1).
        block_size: build in crack-free blocks of this many samples a side,
            merged (0: the whole grid at once). Not used with ``triangles``.
        prune: remove the inserted vertices the bound no longer needs.
        threads: at most this many threads (default: all cores).

    Returns:
        ``(vertices, faces, report)``: vertices ``(n, 3)`` with ``x`` = column x
        cell size, ``y`` = row x cell size, ``z`` = height (float64 for a float64
        grid, else float32), faces int32, counter-clockwise seen from ``+z``;
        ``report`` with ``width``, ``height``, ``samples``, ``voids_filled``,
        ``triangles``, ``vertices``, ``max_error`` and ``rms_error`` (measured
        over every sample), ``max_error_bound``, ``block_size``, ``seconds``,
        ``measure_seconds``.

    Raises:
        TypeError: ``heights`` is neither an array nor a path.
        FileNotFoundError: no such file.
        ValueError: a grid smaller than 2 x 2, all void, a malformed file, or an
            option out of range.
    """
    h = heights if isinstance(heights, np.ndarray) else os.fspath(heights)
    return _meshlod.terrain(
        h,
        max_error=max_error,
        triangles=triangles,
        z_scale=z_scale,
        cell_size=cell_size,
        block_size=block_size,
        prune=prune,
        threads=threads,
    )

# Type stubs of the native module meshlod._meshlod (Rust, PyO3). The public API,
# with its docstrings, is meshlod/__init__.py; these are the calls it makes.
from typing import Any, Dict, List, Optional, Tuple

import numpy as np

__version__: str

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
) -> Tuple[np.ndarray, np.ndarray, Dict[str, Any], Dict[str, np.ndarray], np.ndarray]: ...
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
    a_normals: Optional[np.ndarray] = None,
    a_uvs: Optional[np.ndarray] = None,
    a_colors: Optional[np.ndarray] = None,
    b_normals: Optional[np.ndarray] = None,
    b_uvs: Optional[np.ndarray] = None,
    b_colors: Optional[np.ndarray] = None,
) -> Dict[str, Any]: ...
def read(path: str) -> Tuple[np.ndarray, np.ndarray, Dict[str, np.ndarray]]: ...
def write(
    path: str,
    vertices: np.ndarray,
    faces: np.ndarray,
    *,
    normals: Optional[np.ndarray] = None,
    uvs: Optional[np.ndarray] = None,
    colors: Optional[np.ndarray] = None,
    ascii: bool = False,
) -> None: ...
def lod(
    vertices: np.ndarray,
    faces: np.ndarray,
    *,
    levels: Optional[int] = None,
    ratios: Optional[List[float]] = None,
    method: str = "qem",
    pixel_error: float = 1.0,
    screen_height: float = 1080.0,
    fov: float = 60.0,
    samples: Optional[int] = None,
    threads: Optional[int] = None,
) -> Tuple[List[Tuple[np.ndarray, np.ndarray]], Dict[str, Any]]: ...
def terrain(
    heights: Any,
    *,
    max_error: Optional[float] = None,
    triangles: Optional[int] = None,
    z_scale: float = 1.0,
    cell_size: Optional[float] = None,
    block_size: int = 257,
    prune: bool = True,
    threads: Optional[int] = None,
) -> Tuple[np.ndarray, np.ndarray, Dict[str, Any]]: ...

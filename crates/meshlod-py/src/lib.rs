//! `meshlod._meshlod`: the native half of the `meshlod` Python package (PyO3 and the
//! `numpy` crate; the public API, its docstrings and types are in
//! `python/meshlod/__init__.py`).
//!
//! Each function checks its arrays and options first (dtype, shape, index range,
//! float32 range: `TypeError`/`ValueError` naming the argument), copies the arrays
//! into the library's buffers, then releases the GIL and runs the library
//! (`meshlod::simplify`, `meshlod::metrics::hausdorff`, `meshlod::lod::build_chain`,
//! `meshlod::terrain`, the readers and writers) in a pool of `threads` threads when
//! given. The library's errors become `ValueError` (files: `FileNotFoundError`,
//! `OSError`) with the library's messages; a panic becomes PyO3's `PanicException`,
//! never a crash. Reports are `dict`s with the field names of the CLI's `--json`.

mod convert;

use convert::{ColorKind, FloatKind, IndexKind};
use meshlod::io::{IoError, WriteOptions};
use meshlod::lod::chain::{build_chain, ChainOptions, Level, LevelSpec, Screen};
use meshlod::mesh::{Mesh, VertexAttributes};
use meshlod::metrics::{self, Distances, OneSided, SamplingOptions};
use meshlod::simplify::{
    simplify_observed, Distance, Method, Phases, SimplifyOptions, StopReason,
    DEFAULT_FIT_ITERATIONS,
};
use meshlod::terrain::{
    build_tin, build_tin_blocked, measure as measure_tin, read_height_field, tin_to_mesh,
    HeightField, TinOptions,
};
use numpy::{PyUntypedArray, PyUntypedArrayMethods};
use pyo3::exceptions::{PyFileNotFoundError, PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};
use serde::Serialize;
use std::path::PathBuf;
use std::time::Instant;

/// A `ValueError` with `message`.
fn value_error(message: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(message.to_string())
}

/// A file error as Python's: a missing file is `FileNotFoundError`, other refusals
/// of the operating system `OSError`, the rest (format, invalid mesh) `ValueError`.
fn io_error(e: IoError) -> PyErr {
    match &e {
        IoError::Io { source, .. } if source.kind() == std::io::ErrorKind::NotFound => {
            PyFileNotFoundError::new_err(e.to_string())
        }
        IoError::Io { .. } => PyOSError::new_err(e.to_string()),
        _ => value_error(e),
    }
}

/// Runs `f` in a pool of `threads` threads (`None`: rayon's global pool, all cores),
/// so every parallel step of the library uses at most that many.
fn in_pool<R: Send>(threads: Option<usize>, f: impl FnOnce() -> R + Send) -> Result<R, String> {
    match threads {
        None => Ok(f()),
        Some(0) => Err("threads=0: give 1 or more (None: all cores)".to_string()),
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map(|pool| pool.install(f))
            .map_err(|e| format!("cannot start {n} threads: {e}")),
    }
}

/// A non-negative count from Python (a negative one is a `ValueError`, not an
/// `OverflowError`).
fn count(value: Option<i64>, name: &str) -> PyResult<Option<usize>> {
    value
        .map(|v| {
            usize::try_from(v).map_err(|_| value_error(format!("{name}={v}: must be 0 or more")))
        })
        .transpose()
}

/// The method named `name` (`"qem"`, `"melax"`, `"vertex-removal"`, `"cluster"`).
fn method(name: &str) -> PyResult<Method> {
    Ok(match name {
        "qem" => Method::Qem,
        "melax" => Method::Melax,
        "vertex-removal" | "vertex_removal" => Method::VertexRemoval,
        "cluster" => Method::Cluster,
        other => {
            return Err(value_error(format!(
                "method={other:?}: expected \"qem\", \"melax\", \"vertex-removal\" or \"cluster\""
            )))
        }
    })
}

/// The optional attribute arrays of a call, with their dtypes to give back.
#[derive(Default)]
struct Attributes {
    normals: Option<(Vec<[f32; 3]>, FloatKind)>,
    uvs: Option<(Vec<[f32; 2]>, FloatKind)>,
    colors: Option<(Vec<[f32; 4]>, ColorKind, usize)>,
}

impl Attributes {
    /// Reads the arrays given (each must have one row per vertex, `vertices`).
    fn read(
        normals: Option<&Bound<'_, PyAny>>,
        uvs: Option<&Bound<'_, PyAny>>,
        colors: Option<&Bound<'_, PyAny>>,
        vertices: usize,
    ) -> PyResult<Self> {
        let rows = |name: &str, n: usize| {
            if n == vertices {
                Ok(())
            } else {
                Err(value_error(format!(
                    "{name} has {n} rows for {vertices} vertices (one per vertex)"
                )))
            }
        };
        let mut a = Self::default();
        if let Some(o) = normals {
            let (v, k) = convert::float_rows::<3>(o, "normals")?;
            rows("normals", v.len())?;
            a.normals = Some((v, k));
        }
        if let Some(o) = uvs {
            let (v, k) = convert::float_rows::<2>(o, "uvs")?;
            rows("uvs", v.len())?;
            a.uvs = Some((v, k));
        }
        if let Some(o) = colors {
            let (v, k, c) = convert::colors(o, "colors")?;
            rows("colors", v.len())?;
            a.colors = Some((v, k, c));
        }
        Ok(a)
    }

    /// Moves the streams into `VertexAttributes`, keeping the dtypes to give back.
    fn split(self) -> (VertexAttributes, Kinds) {
        let kinds = Kinds {
            normals: self.normals.as_ref().map(|n| n.1),
            uvs: self.uvs.as_ref().map(|u| u.1),
            colors: self.colors.as_ref().map(|c| (c.1, c.2)),
        };
        let streams = VertexAttributes {
            normals: self.normals.map(|n| n.0),
            uv0: self.uvs.map(|u| u.0),
            colors: self.colors.map(|c| c.0),
            ..VertexAttributes::default()
        };
        (streams, kinds)
    }
}

/// The dtypes the attribute arrays came in (`None`: given back in the library's
/// own, `float32`).
#[derive(Debug, Clone, Copy, Default)]
struct Kinds {
    normals: Option<FloatKind>,
    uvs: Option<FloatKind>,
    colors: Option<(ColorKind, usize)>,
}

/// The streams of `attributes` present as a `dict` of arrays (`normals`, `uvs`,
/// `colors`) in the dtypes of `kinds`.
fn attribute_dict<'py>(
    py: Python<'py>,
    attributes: VertexAttributes,
    kinds: Kinds,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    if let Some(n) = attributes.normals {
        let k = kinds.normals.unwrap_or(FloatKind::F32);
        d.set_item("normals", convert::float_array(py, n, k)?)?;
    }
    if let Some(uv) = attributes.uv0 {
        let k = kinds.uvs.unwrap_or(FloatKind::F32);
        d.set_item("uvs", convert::float_array(py, uv, k)?)?;
    }
    if let Some(c) = attributes.colors {
        let (k, cols) = kinds
            .colors
            .unwrap_or((ColorKind::Float(FloatKind::F32), 4));
        d.set_item("colors", convert::color_array(py, c, k, cols)?)?;
    }
    Ok(d)
}

/// A mesh from Python arrays: positions, triangles and the attribute arrays
/// given, with the dtypes to give back. `prefix` names the arguments in messages.
fn mesh_from(
    vertices: &Bound<'_, PyAny>,
    faces: &Bound<'_, PyAny>,
    prefix: &str,
    normals: Option<&Bound<'_, PyAny>>,
    uvs: Option<&Bound<'_, PyAny>>,
    colors: Option<&Bound<'_, PyAny>>,
) -> PyResult<(Mesh, FloatKind, IndexKind, Kinds)> {
    let (positions, fk) = convert::float_rows::<3>(vertices, &format!("{prefix}vertices"))?;
    let (triangles, ik) = convert::faces(faces, &format!("{prefix}faces"))?;
    let attributes = Attributes::read(normals, uvs, colors, positions.len())?;
    let (streams, kinds) = attributes.split();
    let mesh = Mesh {
        positions,
        triangles,
        attributes: streams,
        ..Mesh::default()
    };
    Ok((mesh, fk, ik, kinds))
}

/// The report of `simplify`: the fields of `meshlod simplify --json` that apply to
/// arrays (no file names, read or write times, memory).
#[derive(Serialize)]
struct SimplifyReport {
    method: &'static str,
    triangles_in: usize,
    vertices_in: usize,
    target_triangles: usize,
    triangles_out: usize,
    vertices_out: usize,
    error: f64,
    error_relative: f64,
    error_absolute: f64,
    error_units: &'static str,
    bbox_diagonal: f64,
    stop_reason: StopReason,
    stop_detail: String,
    seconds: f64,
    collapses: usize,
    non_edge_contractions: usize,
    degenerate_removed: usize,
    duplicate_removed: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    non_manifold_points_in: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    non_manifold_kept: Option<meshlod::collapse::NonManifoldPoints>,
    facing_flips: usize,
    retries: usize,
    holes_closed: usize,
    components_removed: usize,
    fit_moved: usize,
    attributes_refit: usize,
    edge_swaps: usize,
    flat_shading: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    facing_away: Option<[usize; 2]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    hausdorff: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    measure: Option<Distances>,
    #[serde(skip_serializing_if = "Option::is_none")]
    non_manifold_edges: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    non_manifold_vertices: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    cluster: Option<meshlod::decimate::cluster::ClusterStats>,
    phase_seconds: Phases,
}

/// Native `simplify`: returns `(vertices, faces, report, attributes, vertex_source)`.
#[pyfunction]
#[pyo3(signature = (
    vertices, faces, *, ratio=None, triangles=None, max_error=None, absolute=false,
    method="qem", lock_boundary=false, locked=None, fit=false, swap=false, measure=false,
    threads=None, normals=None, uvs=None, colors=None, free_topology=false,
    permissive=false, strict_seams=false
))]
#[allow(clippy::too_many_arguments)]
fn simplify<'py>(
    py: Python<'py>,
    vertices: &Bound<'py, PyAny>,
    faces: &Bound<'py, PyAny>,
    ratio: Option<f64>,
    triangles: Option<i64>,
    max_error: Option<f64>,
    absolute: bool,
    method: &str,
    lock_boundary: bool,
    locked: Option<&Bound<'py, PyAny>>,
    fit: bool,
    swap: bool,
    measure: bool,
    threads: Option<i64>,
    normals: Option<&Bound<'py, PyAny>>,
    uvs: Option<&Bound<'py, PyAny>>,
    colors: Option<&Bound<'py, PyAny>>,
    free_topology: bool,
    permissive: bool,
    strict_seams: bool,
) -> PyResult<Bound<'py, PyTuple>> {
    let method = self::method(method)?;
    let threads = count(threads, "threads")?;
    let (mesh, fk, ik, kinds) = mesh_from(vertices, faces, "", normals, uvs, colors)?;
    let n = mesh.positions.len();
    let dist = |v: f64| {
        if absolute {
            Distance::Absolute(v)
        } else {
            Distance::Relative(v)
        }
    };
    let mut opts = SimplifyOptions::default()
        .with_method(method)
        .with_lock_boundary(lock_boundary)
        .with_preserve_topology(!free_topology)
        .with_threads(threads);
    opts.permissive = permissive;
    opts.strict_seams = strict_seams;
    if let Some(r) = ratio {
        opts = opts.with_ratio(r);
    }
    if let Some(t) = count(triangles, "triangles")? {
        opts = opts.with_target_triangles(t);
    }
    if let Some(e) = max_error {
        opts = opts.with_max_error(dist(e));
    }
    if let Some(mask) = locked {
        opts = opts.with_locked_vertices(convert::mask(mask, "locked")?);
    }
    if swap || fit {
        opts = opts.with_edge_swaps(true);
    }
    if fit {
        opts = opts.with_fit_iterations(DEFAULT_FIT_ITERATIONS);
    }
    let run = py
        .detach(|| {
            in_pool(threads, || {
                simplify_observed(&mesh, &opts, &mut meshlod::decimate::NoObserver).map(|s| {
                    let d = measure
                        .then(|| metrics::hausdorff(&mesh, &s.mesh, &SamplingOptions::default()));
                    (s, d)
                })
            })
        })
        .map_err(value_error)?;
    let (s, distances) = run.map_err(value_error)?;
    drop(mesh);
    let r = s.report;
    let rel = if r.bbox_diagonal > 0.0 {
        r.error_absolute / r.bbox_diagonal
    } else {
        0.0
    };
    let report = SimplifyReport {
        method: r.method,
        triangles_in: r.triangles_in,
        vertices_in: r.vertices_in,
        target_triangles: r.target_triangles,
        triangles_out: r.triangles_out,
        vertices_out: r.vertices_out,
        error: if absolute { r.error_absolute } else { rel },
        error_relative: rel,
        error_absolute: r.error_absolute,
        error_units: if absolute {
            "mesh units"
        } else {
            "fraction of bounding-box diagonal"
        },
        bbox_diagonal: r.bbox_diagonal,
        stop_reason: r.stop_reason,
        stop_detail: r.stop_detail,
        seconds: r.seconds,
        collapses: r.collapses,
        non_edge_contractions: r.non_edge_contractions,
        degenerate_removed: r.degenerate_removed,
        duplicate_removed: r.duplicate_removed,
        non_manifold_points_in: r.non_manifold_points_in,
        non_manifold_kept: r.non_manifold_kept,
        facing_flips: r.facing_flips,
        retries: r.retries,
        holes_closed: r.holes_closed,
        components_removed: r.components_removed,
        fit_moved: r.fit_moved,
        attributes_refit: r.attributes_refit,
        edge_swaps: r.edge_swaps,
        flat_shading: r.flat_shading,
        facing_away: r.facing_away,
        hausdorff: distances.map(|d| {
            if absolute || d.bbox_diagonal <= 0.0 {
                d.hausdorff
            } else {
                d.hausdorff / d.bbox_diagonal
            }
        }),
        measure: distances,
        non_manifold_edges: r.cluster.as_ref().map(|c| c.non_manifold_edges),
        non_manifold_vertices: r.cluster.as_ref().map(|c| c.non_manifold_vertices),
        cluster: r.cluster,
        phase_seconds: r.phases,
    };
    let out = s.mesh;
    let n_out = out.positions.len();
    let v = convert::float_array(py, out.positions, fk)?;
    let f = convert::index_array(py, out.triangles, n_out, ik)?;
    let a = attribute_dict(py, out.attributes, kinds)?;
    let sources = convert::index_array_1d(py, s.vertex_source, n, ik)?;
    PyTuple::new(
        py,
        [v, f, convert::report(py, &report)?, a.into_any(), sources],
    )
}

/// One direction of `measure`'s report, relative values.
#[derive(Serialize)]
struct Relative {
    hausdorff: f64,
    mean: f64,
    rms: f64,
}

/// The report of `measure`: the fields of `meshlod measure --json` (without the
/// file names and the screen-space block).
#[derive(Serialize)]
struct MeasureReport {
    units: &'static str,
    hausdorff: f64,
    max_lower: f64,
    max_upper: Option<f64>,
    mean: f64,
    rms: f64,
    a_to_b: OneSided,
    b_to_a: OneSided,
    relative_to_bbox_diagonal: Relative,
    relative_to_max_extent: Relative,
    bbox_diagonal: f64,
    max_extent: f64,
    samples: u64,
    seconds: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    appearance: Option<metrics::appearance::Appearance>,
    #[serde(skip_serializing_if = "Option::is_none")]
    appearance_seconds: Option<f64>,
}

/// Native `measure`: the report `dict`.
#[pyfunction]
#[pyo3(signature = (
    a_vertices, a_faces, b_vertices, b_faces, *, samples=None, seed=0, threads=None,
    certify=true, appearance=true, a_normals=None, a_uvs=None, a_colors=None,
    b_normals=None, b_uvs=None, b_colors=None
))]
#[allow(clippy::too_many_arguments)]
fn measure<'py>(
    py: Python<'py>,
    a_vertices: &Bound<'py, PyAny>,
    a_faces: &Bound<'py, PyAny>,
    b_vertices: &Bound<'py, PyAny>,
    b_faces: &Bound<'py, PyAny>,
    samples: Option<i64>,
    seed: u64,
    threads: Option<i64>,
    certify: bool,
    appearance: bool,
    a_normals: Option<&Bound<'py, PyAny>>,
    a_uvs: Option<&Bound<'py, PyAny>>,
    a_colors: Option<&Bound<'py, PyAny>>,
    b_normals: Option<&Bound<'py, PyAny>>,
    b_uvs: Option<&Bound<'py, PyAny>>,
    b_colors: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let threads = count(threads, "threads")?;
    let samples = count(samples, "samples")?;
    if samples == Some(0) {
        return Err(value_error("samples=0: must be at least 1"));
    }
    let (a, ..) = mesh_from(a_vertices, a_faces, "a_", a_normals, a_uvs, a_colors)?;
    let (b, ..) = mesh_from(b_vertices, b_faces, "b_", b_normals, b_uvs, b_colors)?;
    for (name, m) in [("a", &a), ("b", &b)] {
        m.validate()
            .map_err(|e| value_error(format!("{name}: invalid mesh: {e}")))?;
        if m.triangles.is_empty() {
            return Err(value_error(format!("{name}: has no triangles to measure")));
        }
    }
    let options = SamplingOptions {
        samples,
        seed,
        certify,
        ..SamplingOptions::default()
    };
    let start = Instant::now();
    let d = py
        .detach(|| in_pool(threads, || metrics::hausdorff(&a, &b, &options)))
        .map_err(value_error)?;
    let seconds = start.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let deviation = if appearance {
        py.detach(|| {
            in_pool(threads, || {
                metrics::appearance::appearance(&a, &b, &options)
            })
        })
        .map_err(value_error)?
    } else {
        None
    };
    let appearance_seconds = deviation.is_some().then(|| t1.elapsed().as_secs_f64());
    let relative = |scale: f64| {
        let s = d.scaled(scale);
        Relative {
            hausdorff: s.hausdorff,
            mean: s.mean,
            rms: s.rms,
        }
    };
    let report = MeasureReport {
        units: "mesh units",
        hausdorff: d.hausdorff,
        max_lower: d.hausdorff,
        max_upper: d.hausdorff_upper,
        mean: d.mean,
        rms: d.rms,
        a_to_b: d.a_to_b,
        b_to_a: d.b_to_a,
        relative_to_bbox_diagonal: relative(d.bbox_diagonal),
        relative_to_max_extent: relative(d.max_extent),
        bbox_diagonal: d.bbox_diagonal,
        max_extent: d.max_extent,
        samples: d.a_to_b.samples + d.b_to_a.samples,
        seconds,
        appearance: deviation,
        appearance_seconds,
    };
    convert::report(py, &report)
}

/// Native `read`: `(vertices, faces, attributes)` of the file flattened into one
/// mesh (as the CLI reads it).
#[pyfunction]
fn read(py: Python<'_>, path: PathBuf) -> PyResult<Bound<'_, PyTuple>> {
    let mesh = py.detach(|| meshlod::read_mesh(&path)).map_err(io_error)?;
    let n = mesh.positions.len();
    let v = convert::float_array(py, mesh.positions, FloatKind::F32)?;
    let f = convert::index_array(py, mesh.triangles, n, IndexKind::I32)?;
    let a = attribute_dict(py, mesh.attributes, Kinds::default())?;
    PyTuple::new(py, [v, f, a.into_any()])
}

/// Native `write`: the mesh to `path`, the format by its extension.
#[pyfunction]
#[pyo3(signature = (path, vertices, faces, *, normals=None, uvs=None, colors=None, ascii=false))]
#[allow(clippy::too_many_arguments)]
fn write(
    py: Python<'_>,
    path: PathBuf,
    vertices: &Bound<'_, PyAny>,
    faces: &Bound<'_, PyAny>,
    normals: Option<&Bound<'_, PyAny>>,
    uvs: Option<&Bound<'_, PyAny>>,
    colors: Option<&Bound<'_, PyAny>>,
    ascii: bool,
) -> PyResult<()> {
    let (mesh, ..) = mesh_from(vertices, faces, "", normals, uvs, colors)?;
    mesh.validate()
        .map_err(|e| value_error(format!("{}: invalid mesh: {e}", path.display())))?;
    let options = WriteOptions::default().with_ascii(ascii);
    py.detach(|| meshlod::write_mesh(&path, &mesh, &options))
        .map_err(io_error)
}

/// The report of `lod`: the chain (levels with their errors and switch distances,
/// bounding sphere, times) and the screen it was built for.
#[derive(Serialize)]
struct LodReport<'a> {
    method: &'static str,
    pixel_error: f64,
    screen_height_px: f64,
    fov_degrees: f64,
    units: &'static str,
    levels: &'a [Level],
    center: [f64; 3],
    radius: f64,
    cull_coverage: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    stopped_early: Option<String>,
    simplify_seconds: f64,
    measure_seconds: f64,
}

/// Native `lod`: `(levels, report)`, `levels` a list of `(vertices, faces)` from
/// LOD0 (the input) to the coarsest.
#[pyfunction]
#[pyo3(signature = (
    vertices, faces, *, levels=None, ratios=None, method="qem", pixel_error=1.0,
    screen_height=1080.0, fov=60.0, samples=None, threads=None
))]
#[allow(clippy::too_many_arguments)]
fn lod<'py>(
    py: Python<'py>,
    vertices: &Bound<'py, PyAny>,
    faces: &Bound<'py, PyAny>,
    levels: Option<i64>,
    ratios: Option<Vec<f64>>,
    method: &str,
    pixel_error: f64,
    screen_height: f64,
    fov: f64,
    samples: Option<i64>,
    threads: Option<i64>,
) -> PyResult<Bound<'py, PyTuple>> {
    let method = self::method(method)?;
    let threads = count(threads, "threads")?;
    let samples = count(samples, "samples")?;
    if samples == Some(0) {
        return Err(value_error("samples=0: must be at least 1"));
    }
    let spec = match (ratios, count(levels, "levels")?) {
        (Some(_), Some(_)) => return Err(value_error("give levels= or ratios=, not both")),
        (Some(r), None) => LevelSpec::Ratios(r),
        (None, Some(n)) => LevelSpec::ByError(n),
        (None, None) => LevelSpec::ByError(4),
    };
    let (mesh, fk, ik, _) = mesh_from(vertices, faces, "", None, None, None)?;
    let options = ChainOptions {
        levels: spec,
        simplify: SimplifyOptions::default()
            .with_method(method)
            .with_threads(threads),
        sampling: SamplingOptions {
            samples,
            ..SamplingOptions::default()
        },
        screen: Screen {
            pixel_error,
            screen_height_px: screen_height,
            fov_degrees: fov,
            ..Screen::default()
        },
        geomorph: false,
    };
    let chain = py
        .detach(|| in_pool(threads, || build_chain(&mesh, &options)))
        .map_err(value_error)?
        .map_err(value_error)?;
    drop(mesh);
    let report = LodReport {
        method: method.name(),
        pixel_error,
        screen_height_px: screen_height,
        fov_degrees: fov,
        units: "mesh units",
        levels: &chain.levels,
        center: chain.center,
        radius: chain.radius,
        cull_coverage: chain.cull_coverage,
        stopped_early: chain.stopped_early.clone(),
        simplify_seconds: chain.simplify_seconds,
        measure_seconds: chain.measure_seconds,
    };
    let report = convert::report(py, &report)?;
    let list = PyList::empty(py);
    for level in chain.levels {
        let n = level.mesh.positions.len();
        let v = convert::float_array(py, level.mesh.positions, fk)?;
        let f = convert::index_array(py, level.mesh.triangles, n, ik)?;
        list.append(PyTuple::new(py, [v, f])?)?;
    }
    PyTuple::new(py, [list.into_any(), report])
}

/// The report of `terrain`: the fields of `meshlod terrain --json` for one TIN.
#[derive(Serialize)]
struct TerrainReport {
    width: usize,
    height: usize,
    samples: usize,
    voids_filled: usize,
    triangles: usize,
    vertices: usize,
    max_error: f64,
    rms_error: f64,
    max_error_bound: Option<f64>,
    block_size: Option<usize>,
    seconds: f64,
    measure_seconds: f64,
}

/// Native `terrain`: `(vertices, faces, report)` of the TIN of a height grid (a 2-D
/// array, rows first) or a height-field file.
#[pyfunction]
#[pyo3(signature = (
    heights, *, max_error=None, triangles=None, z_scale=1.0, cell_size=None,
    block_size=257, prune=true, threads=None
))]
#[allow(clippy::too_many_arguments)]
fn terrain<'py>(
    py: Python<'py>,
    heights: &Bound<'py, PyAny>,
    max_error: Option<f64>,
    triangles: Option<i64>,
    z_scale: f64,
    cell_size: Option<f64>,
    block_size: i64,
    prune: bool,
    threads: Option<i64>,
) -> PyResult<Bound<'py, PyTuple>> {
    let threads = count(threads, "threads")?;
    let triangles = count(triangles, "triangles")?;
    let block_size = count(Some(block_size), "block_size")?.unwrap_or(0);
    let bound = match (max_error, triangles) {
        (Some(e), _) => e,
        (None, Some(_)) => 0.0,
        (None, None) => 1.0,
    };
    if !(bound >= 0.0 && bound.is_finite()) {
        return Err(value_error(format!(
            "max_error={bound}: must be a non-negative number"
        )));
    }
    if !(z_scale.is_finite() && z_scale != 0.0) {
        return Err(value_error(format!(
            "z_scale={z_scale}: must be a non-zero number"
        )));
    }
    if let Some(c) = cell_size.filter(|c| !(*c > 0.0 && c.is_finite())) {
        return Err(value_error(format!("cell_size={c}: must be positive")));
    }
    if block_size == 1 {
        return Err(value_error(
            "block_size=1: a block needs at least 2 samples a side (0: no blocks)",
        ));
    }
    let (mut hf, fk) = if let Ok(array) = heights.cast::<PyUntypedArray>() {
        let shape = array.shape().to_vec();
        let [rows, cols] = shape[..] else {
            return Err(value_error(format!(
                "heights must be a 2-D array (rows, columns), got {} dimensions",
                shape.len()
            )));
        };
        let (values, fk) = convert::float_grid(array, "heights")?;
        let hf = HeightField::from_heights(cols, rows, values)
            .map_err(|e| value_error(format!("heights: {e}")))?;
        (hf, fk)
    } else {
        let path: PathBuf = heights.extract().map_err(|_| {
            pyo3::exceptions::PyTypeError::new_err(
                "heights must be a 2-D numpy array or a path to a height field (.png, .hgt, .asc, .tif)",
            )
        })?;
        let hf = py
            .detach(|| read_height_field(&path))
            .map_err(|e| match &e.problem {
                meshlod::terrain::heightfield::Problem::Io(io)
                    if io.kind() == std::io::ErrorKind::NotFound =>
                {
                    PyFileNotFoundError::new_err(e.to_string())
                }
                _ => value_error(e),
            })?;
        (hf, FloatKind::F32)
    };
    hf.scale_heights(z_scale);
    if let Some(c) = cell_size {
        hf.cell_size = c;
    }
    let options = TinOptions {
        max_error: bound,
        max_triangles: triangles,
        prune,
    };
    let blocked = block_size >= 2 && triangles.is_none();
    let start = Instant::now();
    let (tin, seconds, deviation, measure_seconds) = py
        .detach(|| {
            in_pool(threads, || {
                let tin = if blocked {
                    build_tin_blocked(&hf.heights, hf.width, hf.height, block_size, &options)
                } else {
                    build_tin(&hf.heights, hf.width, hf.height, &options)
                }?;
                let seconds = start.elapsed().as_secs_f64();
                let t = Instant::now();
                let dev = measure_tin(&tin, &hf.heights, hf.width);
                Ok::<_, meshlod::terrain::TinError>((tin, seconds, dev, t.elapsed().as_secs_f64()))
            })
        })
        .map_err(value_error)?
        .map_err(value_error)?;
    let report = TerrainReport {
        width: hf.width,
        height: hf.height,
        samples: hf.width * hf.height,
        voids_filled: hf.voids_filled,
        triangles: tin.triangles.len(),
        vertices: tin.points.len(),
        max_error: deviation.max,
        rms_error: deviation.rms,
        max_error_bound: max_error.or(triangles.is_none().then_some(bound)),
        block_size: blocked.then_some(block_size),
        seconds,
        measure_seconds,
    };
    let mesh = tin_to_mesh(&tin, &hf);
    let n = mesh.positions.len();
    let v = convert::float_array(py, mesh.positions, fk)?;
    let f = convert::index_array(py, mesh.triangles, n, IndexKind::I32)?;
    PyTuple::new(py, [v, f, convert::report(py, &report)?])
}

/// The extension module `meshlod._meshlod`.
#[pymodule]
fn _meshlod(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(simplify, m)?)?;
    m.add_function(wrap_pyfunction!(measure, m)?)?;
    m.add_function(wrap_pyfunction!(read, m)?)?;
    m.add_function(wrap_pyfunction!(write, m)?)?;
    m.add_function(wrap_pyfunction!(lod, m)?)?;
    m.add_function(wrap_pyfunction!(terrain, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}

#!/usr/bin/env python3
"""meshlod's Python package against the Python simplifiers, in one process.

For each mesh and ratio, every simplifier gets the same numpy arrays (read once by
`meshlod.read`) and the same triangle target; the simplification call alone is
timed (best of --reps, the peers' input conversion done before the clock starts,
as the shared peers harness does), and the output is measured against the input
with `meshlod.measure` (two-sided Hausdorff, Metro sampling with the default
samples; unreferenced vertices of a peer's output dropped first, so only the
surface is measured). Distances are % of the input's bounding-box diagonal.

Peers (each skipped with a notice when not installed):
  fast_simplification  fast_simplification.simplify(target_count, agg=7, preserve_border=False)
  pymeshlab            MeshSet.meshing_decimation_quadric_edge_collapse(targetfacenum), defaults
  open3d               TriangleMesh.simplify_quadric_decimation(target_number_of_triangles)
  meshoptimizer        meshoptimizer.simplify(target_index_count, target_error=1.0, options=0)

    python bench/python_peers.py --meshes ../shared/meshes --ratio 0.1 0.01 --reps 3
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np

import meshlod

MESHES = {
    "bunny": "common-3d-test-models/stanford-bunny.obj",
    "fandisk": "common-3d-test-models/fandisk.obj",
    "armadillo": "libigl-tutorial-data/armadillo.obj",
    "lucy": "vtk-data/lucy.ply",
    "turbineblade": "vtk-data/turbineblade.ply",
}


def make_peers():
    """name -> (prepare(v, f, target) -> run() -> (vertices, faces)); the timed part
    is run()."""
    peers = {}

    def ours(v, f, target):
        v32, f32 = np.ascontiguousarray(v, np.float32), np.ascontiguousarray(f, np.int32)
        return lambda: meshlod.simplify(v32, f32, triangles=target)[:2]

    peers["meshlod"] = ours
    try:
        import fast_simplification as fs

        def fast(v, f, target):
            v64, f32 = np.ascontiguousarray(v, np.float64), np.ascontiguousarray(f, np.int32)
            return lambda: fs.simplify(v64, f32, target_count=target, agg=7.0, preserve_border=False)

        peers["fast_simplification"] = fast
    except ImportError:
        print("fast_simplification not installed: skipped", file=sys.stderr)
    try:
        import pymeshlab

        def pml(v, f, target):
            v64, f32 = np.ascontiguousarray(v, np.float64), np.ascontiguousarray(f, np.int32)
            state = {}

            def run():
                ms = pymeshlab.MeshSet()  # building the MeshSet is not timed (see main)
                ms.add_mesh(pymeshlab.Mesh(v64, f32))
                state["ms"] = ms
                t = time.perf_counter()
                ms.meshing_decimation_quadric_edge_collapse(targetfacenum=target)
                state["t"] = time.perf_counter() - t
                m = ms.current_mesh()
                return m.vertex_matrix(), m.face_matrix()

            run.inner_time = state  # the call's own time, without building the set
            return run

        peers["pymeshlab"] = pml
    except ImportError:
        print("pymeshlab not installed: skipped", file=sys.stderr)
    try:
        import open3d as o3d

        def o3d_qem(v, f, target):
            mesh = o3d.geometry.TriangleMesh(
                o3d.utility.Vector3dVector(np.ascontiguousarray(v, np.float64)),
                o3d.utility.Vector3iVector(np.ascontiguousarray(f, np.int32)),
            )

            def run():
                m = mesh.simplify_quadric_decimation(target_number_of_triangles=target)
                return np.asarray(m.vertices), np.asarray(m.triangles)

            return run

        peers["open3d"] = o3d_qem
    except ImportError:
        print("open3d not installed: skipped", file=sys.stderr)
    try:
        import meshoptimizer as mo

        def mopt(v, f, target):
            pos = np.ascontiguousarray(v, np.float32)
            idx = np.ascontiguousarray(f, np.uint32).ravel()

            def run():
                dest = np.empty(len(idx), np.uint32)
                n = mo.simplify(dest, idx, pos, target_index_count=3 * target, target_error=1.0, options=0)
                return pos, dest[:n].reshape(-1, 3)

            return run

        peers["meshoptimizer"] = mopt
    except ImportError:
        print("meshoptimizer not installed: skipped", file=sys.stderr)
    return peers


def compact(v, f):
    """The vertices the triangles use, and the triangles renumbered."""
    f = np.asarray(f, dtype=np.int64)
    used, inverse = np.unique(f.ravel(), return_inverse=True)
    return np.ascontiguousarray(np.asarray(v)[used], np.float64), inverse.reshape(-1, 3)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--meshes", default="../shared/meshes", help="the shared mesh folder")
    ap.add_argument("--only", nargs="*", default=list(MESHES), help="mesh names")
    ap.add_argument("--ratio", nargs="+", type=float, default=[0.1, 0.01])
    ap.add_argument("--reps", type=int, default=3, help="timed runs per cell (best is kept)")
    ap.add_argument("--json", help="write the rows here too")
    args = ap.parse_args()
    peers = make_peers()
    rows = []
    for name in args.only:
        v, f, _ = meshlod.read(Path(args.meshes) / MESHES[name])
        for ratio in args.ratio:
            target = round(ratio * len(f))
            for peer, prepare in peers.items():
                run = prepare(v, f, target)
                best = float("inf")
                for _ in range(args.reps):
                    t = time.perf_counter()
                    out = run()
                    dt = time.perf_counter() - t
                    inner = getattr(run, "inner_time", None)
                    best = min(best, inner["t"] if inner else dt)
                ov, of = compact(*out)
                d = meshlod.measure(v, f, ov, of)
                row = {
                    "mesh": name,
                    "ratio": ratio,
                    "target": target,
                    "peer": peer,
                    "triangles": int(len(of)),
                    "seconds": best,
                    "hausdorff_pct": 100 * d["relative_to_bbox_diagonal"]["hausdorff"],
                    "mean_pct": 100 * d["relative_to_bbox_diagonal"]["mean"],
                }
                rows.append(row)
                print(
                    f"{name:13} {ratio:5} {peer:20} {row['triangles']:7d} tris "
                    f"{best * 1000:9.1f} ms  max {row['hausdorff_pct']:.4f}%  mean {row['mean_pct']:.5f}%",
                    flush=True,
                )
    print()
    print("| mesh | ratio | peer | triangles | time (ms) | time / meshlod | Hausdorff max (%) | mean (%) |")
    print("|---|---|---|---:|---:|---:|---:|---:|")
    for r in rows:
        ours = next(x for x in rows if x["mesh"] == r["mesh"] and x["ratio"] == r["ratio"] and x["peer"] == "meshlod")
        print(
            f"| {r['mesh']} | {r['ratio']} | {r['peer']} | {r['triangles']:,} | {r['seconds'] * 1000:.1f} "
            f"| {r['seconds'] / ours['seconds']:.2f} | {r['hausdorff_pct']:.4f} | {r['mean_pct']:.5f} |"
        )
    print(f"\npython {platform.python_version()}, numpy {np.__version__}, meshlod {meshlod.__version__}")
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()

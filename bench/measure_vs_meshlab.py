#!/usr/bin/env python3
"""Agreement and speed of `meshlod measure` against MeshLab's Hausdorff filter.

For each mesh, makes a simplified version with MeshLab's quadric edge collapse (10% of
the triangles, written as PLY), then measures the pair both ways with
  - pymeshlab `get_hausdorff_distance` (vertex + edge + face sampling, samplenum N), run
    in both directions, symmetric max = max of the two maxima, symmetric mean = max of the
    two means (the peers harness's definitions), and
  - `meshlod measure ORIGINAL SIMPLIFIED --samples N --json`,
and prints a table: both numbers, their relative difference, and both times.

Usage (with the peers harness venv, which has pymeshlab):
    cargo build --release -p meshlod-cli
    /work/bench/.venv/bin/python bench/measure_vs_meshlab.py [--samples N] MESH...

Goal (issue "meshlod measure"): agreement within 3% (max) and 2% (mean); >= 3x faster.
"""
import argparse, json, os, subprocess, sys, tempfile, time

import numpy as np
import pymeshlab

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "target", "release", "meshlod")


def meshlab_pair(ms, n):
    out = {}
    t0 = time.perf_counter()
    for name, smp, tgt in (("a_to_b", 0, 1), ("b_to_a", 1, 0)):
        r = ms.get_hausdorff_distance(sampledmesh=smp, targetmesh=tgt, samplevert=True,
                                      sampleedge=True, sampleface=True, samplenum=n)
        out[name] = r
    out["seconds"] = time.perf_counter() - t0
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("meshes", nargs="+")
    ap.add_argument("--samples", type=int, default=1_000_000)
    ap.add_argument("--ratio", type=float, default=0.1)
    ap.add_argument("--subdivide", type=int, default=0,
                    help="midpoint-subdivide each mesh K times first (x4 triangles each), "
                         "e.g. the bunny with K=2 gives the 1.1M-triangle pair of the speed goal")
    a = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for path in a.meshes:
            ms = pymeshlab.MeshSet()
            ms.load_new_mesh(path)
            if a.subdivide:
                ms.meshing_remove_unreferenced_vertices()
                ms.meshing_surface_subdivision_midpoint(iterations=a.subdivide,
                                                        threshold=pymeshlab.PercentageValue(0))
            orig = os.path.join(tmp, "orig.ply")
            ms.save_current_mesh(orig, binary=True)
            nf = ms.current_mesh().face_number()
            ms.meshing_decimation_quadric_edge_collapse(targetfacenum=max(4, int(nf * a.ratio)))
            simp = os.path.join(tmp, "simp.ply")
            ms.save_current_mesh(simp, binary=True)
            pair = pymeshlab.MeshSet()
            pair.load_new_mesh(orig)
            pair.load_new_mesh(simp)
            diag = pair.mesh(0).bounding_box().diagonal()
            ml = meshlab_pair(pair, a.samples)
            t0 = time.perf_counter()
            p = subprocess.run([BIN, "measure", orig, simp, "--samples", str(a.samples), "--json"],
                               capture_output=True, text=True, check=True)
            ours_wall = time.perf_counter() - t0
            ours = json.loads(p.stdout.strip().splitlines()[-1])
            ml_max = max(ml["a_to_b"]["max"], ml["b_to_a"]["max"]) / diag
            ml_mean = max(ml["a_to_b"]["mean"], ml["b_to_a"]["mean"]) / diag
            o_max = ours["relative_to_bbox_diagonal"]["hausdorff"]
            o_mean = ours["relative_to_bbox_diagonal"]["mean"]
            rows.append((f"{os.path.basename(path)} ({nf} tris)", ml_max, o_max, ml_mean, o_mean,
                         ml["seconds"], ours["seconds"], ours_wall,
                         int(ml["a_to_b"]["n_samples"]), int(ours["a_to_b"]["samples"])))
    if a.subdivide:
        print(f"each mesh midpoint-subdivided {a.subdivide}x first")
    print(f"samplenum {a.samples}, simplified to {a.ratio:g} with MeshLab QEM; values in % of bbox diagonal\n")
    print("| mesh | H max MeshLab | H max ours | diff | H mean MeshLab | H mean ours | diff | MeshLab s | ours s (in-process) | ours s (process) | speed-up | samples ML/ours (A->B) |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        name, mlm, om, mlmean, omean, mls, os_, ow, mln, on = r
        print(f"| {name} | {100*mlm:.4f} | {100*om:.4f} | {100*(om-mlm)/mlm:+.1f}% | {100*mlmean:.5f} | {100*omean:.5f} | "
              f"{100*(omean-mlmean)/mlmean:+.1f}% | {mls:.2f} | {os_:.2f} | {ow:.2f} | {mls/os_:.1f}x | {mln}/{on} |")


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env python3
"""What the Python layer adds to a `meshlod.simplify` call on a large mesh.

The armadillo (86,482 triangles) is split twice, each triangle into four at its
edge midpoints (1,383,712 triangles; the surface is unchanged, so the run is a
real one), then simplified from Python several times, alternating the input
dtypes. Each call's wall-clock time (numpy in, library, numpy out, report dict) is
compared with the library's own time of the same call, `report["seconds"]` (the
clock inside `meshlod::simplify`, from validation to the output mesh): the
difference is the Python overhead.

    python bench/python_overhead.py --mesh ../shared/meshes/libigl-tutorial-data/armadillo.obj
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

import meshlod


def split4(v, f):
    """Each triangle into four at its edge midpoints (shared midpoints welded)."""
    edges = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    key = np.sort(edges, axis=1)
    uniq, inverse = np.unique(key, axis=0, return_inverse=True)
    mid = (v[uniq[:, 0]].astype(np.float64) + v[uniq[:, 1]]) / 2
    m = len(f)
    ids = len(v) + inverse.reshape(3, m).T  # midpoints of edges 01, 12, 20
    a, b, c = f[:, 0], f[:, 1], f[:, 2]
    ab, bc, ca = ids[:, 0], ids[:, 1], ids[:, 2]
    nf = np.concatenate(
        [np.stack(t, axis=1) for t in ((a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca))]
    )
    return np.concatenate([v, mid.astype(np.float32)]), nf.astype(np.int32)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mesh", default="../shared/meshes/libigl-tutorial-data/armadillo.obj")
    ap.add_argument("--splits", type=int, default=2)
    ap.add_argument("--ratio", type=float, nargs="+", default=[0.1, 0.01])
    ap.add_argument("--reps", type=int, default=3)
    args = ap.parse_args()
    v, f, _ = meshlod.read(args.mesh)
    for _ in range(args.splits):
        v, f = split4(v, f)
    print(f"{len(v):,} vertices, {len(f):,} triangles")
    inputs = {
        "float32/int32": (v, f),
        "float64/int64": (v.astype(np.float64), f.astype(np.int64)),
    }
    print("| input dtypes | ratio | Python call (s) | library (s) | overhead (s) | overhead (%) |")
    print("|---|---|---:|---:|---:|---:|")
    for ratio in args.ratio:
        samples = {k: [] for k in inputs}
        for _ in range(args.reps):
            for name, (vv, ff) in inputs.items():  # alternating
                t = time.perf_counter()
                _, _, report = meshlod.simplify(vv, ff, ratio=ratio)
                total = time.perf_counter() - t
                samples[name].append((total, report["seconds"]))
        for name, runs in samples.items():
            total = statistics.median(t for t, _ in runs)
            inner = statistics.median(s for _, s in runs)
            over = statistics.median(t - s for t, s in runs)
            print(f"| {name} | {ratio} | {total:.3f} | {inner:.3f} | {over:.4f} | {100 * over / inner:.2f} |")


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Vertex clustering side by side: meshlod `--method cluster` against VTK's
vtkQuadricClustering and Open3D's simplify_vertex_clustering, at matched triangle
counts, all measured with `meshlod measure --json` (symmetric Hausdorff max and
mean, % of the bounding-box diagonal; Metro sampling, default samples).

Matching: meshlod takes `--ratio R` (its own grid search). VTK and Open3D have no
count target, so their grid (VTK: number of divisions along x, y, z proportional to
the box sides; Open3D: voxel size) is bisected until the output is within 5% of
meshlod's count (or the closest found). The time reported for VTK and Open3D is that of
the final (matched) run only; meshlod's is its whole call including the search.

Usage (peers venv has vtk and open3d):
    cargo build --release -p meshlod-cli
    /work/bench/.venv/bin/python bench/cluster_peers.py [--ratios 0.1 0.01] MESH...
"""
import argparse, json, os, subprocess, sys, tempfile, time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "target", "release", "meshlod")


def run(*args):
    r = subprocess.run([BIN, *args], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"meshlod {' '.join(args)} failed:\n{r.stderr}")
    return r.stdout


def measure(a, b):
    d = json.loads(run("measure", a, b, "--json"))
    diag = d["bbox_diagonal"]
    return 100 * d["hausdorff"] / diag, 100 * d["mean"] / diag


def load_vtk(path):
    import vtk
    ext = os.path.splitext(path)[1].lower()
    reader = {".ply": vtk.vtkPLYReader, ".obj": vtk.vtkOBJReader, ".stl": vtk.vtkSTLReader}[ext]()
    reader.SetFileName(path)
    reader.Update()
    tri = vtk.vtkTriangleFilter()
    tri.SetInputData(reader.GetOutput())
    tri.Update()
    return tri.GetOutput()


def vtk_cluster(poly, divisions):
    import vtk
    b = poly.GetBounds()
    sides = np.array([b[1] - b[0], b[3] - b[2], b[5] - b[4]])
    n = np.maximum(1, np.round(divisions * sides / sides.max())).astype(int)
    q = vtk.vtkQuadricClustering()
    q.SetInputData(poly)
    q.SetNumberOfDivisions(int(n[0]), int(n[1]), int(n[2]))
    q.AutoAdjustNumberOfDivisionsOff()
    t0 = time.perf_counter()
    q.Update()
    return q.GetOutput(), time.perf_counter() - t0


def o3d_cluster(mesh, voxel):
    import open3d as o3d
    t0 = time.perf_counter()
    out = mesh.simplify_vertex_clustering(
        voxel_size=voxel, contraction=o3d.geometry.SimplificationContraction.Quadric)
    return out, time.perf_counter() - t0


def bisect(make, count, target, lo, hi, increasing):
    """Bisects a grid parameter in [lo, hi] (geometric) for count close to target."""
    best = None
    for _ in range(30):
        mid = (lo * hi) ** 0.5
        out, secs = make(mid)
        c = count(out)
        if best is None or abs(c - target) < abs(best[2] - target):
            best = (out, secs, c, mid)
        if abs(c - target) <= 0.05 * target:
            break
        if (c < target) == increasing:
            lo = mid
        else:
            hi = mid
    return best


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("meshes", nargs="+")
    ap.add_argument("--ratios", nargs="+", type=float, default=[0.1, 0.01])
    args = ap.parse_args()
    import vtk
    import open3d as o3d
    tmp = tempfile.mkdtemp(prefix="cluster_peers_")
    print("| mesh | ratio | tool | tris out | seconds | H max % | H mean % |")
    print("|---|---:|---|---:|---:|---:|---:|")
    for path in args.meshes:
        name = os.path.splitext(os.path.basename(path))[0]
        poly = load_vtk(path)
        om = o3d.io.read_triangle_mesh(path)
        diag = np.linalg.norm(om.get_max_bound() - om.get_min_bound())
        for ratio in args.ratios:
            ours = os.path.join(tmp, f"{name}_{ratio}_meshlod.ply")
            rep = json.loads(run("simplify", path, "-o", ours, "--method", "cluster",
                                 "--ratio", str(ratio), "--json"))
            target = rep["triangles_out"]
            rows = [("meshlod cluster", target, rep["seconds"], ours)]

            v = bisect(lambda d: vtk_cluster(poly, d), lambda o: o.GetNumberOfPolys(),
                       target, 1.0, 4096.0, increasing=True)
            vpath = os.path.join(tmp, f"{name}_{ratio}_vtk.ply")
            w = vtk.vtkPLYWriter()
            w.SetFileName(vpath)
            w.SetInputData(v[0])
            w.SetFileTypeToBinary()
            w.Write()
            rows.append((f"vtkQuadricClustering ({int(v[3])} div)", v[2], v[1], vpath))

            o = bisect(lambda s: o3d_cluster(om, s * diag), lambda m: len(m.triangles),
                       target, 1e-5, 0.5, increasing=False)
            opath = os.path.join(tmp, f"{name}_{ratio}_open3d.ply")
            o3d.io.write_triangle_mesh(opath, o[0])
            rows.append((f"Open3D vertex clustering (voxel {o[3]:.2e} diag)", o[2], o[1], opath))

            for tool, n, secs, out in rows:
                hmax, hmean = measure(path, out)
                print(f"| {name} | {ratio} | {tool} | {n} | {secs:.3f} | {hmax:.3f} | {hmean:.4f} |",
                      flush=True)


if __name__ == "__main__":
    main()

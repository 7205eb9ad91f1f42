#!/usr/bin/env python3
"""`meshlod simplify --method vertex-removal` against VTK's vtkDecimatePro.

For each mesh and ratio, at the same target triangle count:
  - vtkDecimatePro with PreserveTopology on and off (TargetReduction = 1 - ratio, other
    options at their defaults: FeatureAngle 15, Splitting on, BoundaryVertexDeletion
    on), timed in-process around `Update()` (the PLY read is not timed);
  - `meshlod simplify IN -o OUT --method vertex-removal --triangles T --json`, whose
    in-process `seconds` (repair + simplification + output, not IO) is recorded;
and every output is measured against the original with
`meshlod measure ORIGINAL OUTPUT --samples N --json` (symmetric Hausdorff max and
mean, Metro sampling, as fractions of the original's bounding-box diagonal) and
`meshlod info --json` (boundary edges, non-manifold edges).

Usage (the peers harness venv has vtk):
    cargo build --release -p meshlod-cli
    /work/bench/.venv/bin/python bench/vertex_removal_vs_vtk.py [--samples N] \
        [--ratios 0.5 0.1 0.01] MESH...

Prints a Markdown table: triangles reached, Hausdorff max / mean (% of diagonal), new
boundary edges, time and input triangles per second.
"""
import argparse, json, os, subprocess, sys, tempfile, time

import vtk

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "target", "release", "meshlod")


def run_json(args):
    out = subprocess.run([BIN] + args, check=True, capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def read_vtk(path):
    r = vtk.vtkPLYReader() if path.endswith(".ply") else vtk.vtkOBJReader()
    r.SetFileName(path)
    r.Update()
    tri = vtk.vtkTriangleFilter()
    tri.SetInputData(r.GetOutput())
    tri.Update()
    clean = vtk.vtkCleanPolyData()  # weld exactly equal points (as meshlod does)
    clean.SetInputData(tri.GetOutput())
    clean.SetTolerance(0.0)
    clean.Update()
    return clean.GetOutput()


def decpro_timed(poly, ratio, preserve):
    """vtkDecimatePro to `ratio` of the triangles (defaults otherwise), run; returns
    the filter and the seconds of its Update() alone."""
    f = vtk.vtkDecimatePro()
    f.SetInputData(poly)
    f.SetTargetReduction(1.0 - ratio)
    f.SetPreserveTopology(1 if preserve else 0)
    t0 = time.perf_counter()
    f.Update()
    return f, time.perf_counter() - t0


def vtk_decpro(poly, ratio, preserve, out_path):
    f, dt = decpro_timed(poly, ratio, preserve)
    w = vtk.vtkPLYWriter()
    w.SetFileName(out_path)
    w.SetInputData(f.GetOutput())
    w.SetFileTypeToBinary()
    w.Write()
    return f.GetOutput().GetNumberOfPolys(), dt


def measure(orig, out, samples):
    m = run_json(["measure", orig, out, "--samples", str(samples), "--json"])
    info = run_json(["info", out, "--json"])
    rel = m["relative_to_bbox_diagonal"]
    return rel["hausdorff"] * 100, rel["mean"] * 100, info["boundary_edges"], info["non_manifold_edges"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("meshes", nargs="+")
    ap.add_argument("--ratios", nargs="+", type=float, default=[0.5, 0.1, 0.01])
    ap.add_argument("--samples", type=int, default=1_000_000)
    a = ap.parse_args()
    print("| mesh | ratio | target | method | triangles | Hausdorff % | mean % | boundary edges (in) | seconds | M tri/s |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    tmp = tempfile.mkdtemp()
    for path in a.meshes:
        name = os.path.basename(path)
        poly = read_vtk(path)
        n_in = poly.GetNumberOfPolys()
        b_in = run_json(["info", path, "--json"])["boundary_edges"]
        for ratio in a.ratios:
            target = round(n_in * ratio)
            rows = []
            for preserve in (True, False):
                out = os.path.join(tmp, f"vtk_{preserve}.ply")
                n, dt = vtk_decpro(poly, ratio, preserve, out)
                label = "vtkDecimatePro topo on" if preserve else "vtkDecimatePro topo off"
                rows.append((label, n, dt, out))
            out = os.path.join(tmp, "ours.ply")
            r = run_json(["simplify", path, "-o", out, "--method", "vertex-removal",
                          "--triangles", str(target), "--json"])
            rows.append(("meshlod vertex-removal", r["triangles_out"], r["seconds"], out))
            for label, n, dt, out in rows:
                h, mean, be, nm = measure(path, out, a.samples)
                print(f"| {name} | {ratio} | {target} | {label} | {n} | {h:.3f} | {mean:.4f} | "
                      f"{be} ({b_in}) | {dt:.3f} | {n_in / dt / 1e6:.2f} |", flush=True)


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env python3
"""Speed ratio of `meshlod simplify --method vertex-removal` to vtkDecimatePro.

For each mesh and ratio, alternates N times: vtkDecimatePro (PreserveTopology on, and
off) timed in-process around `Update()`, and `meshlod simplify ... --json`, whose
in-process `seconds` (repair + simplification + output, IO excluded) is recorded.
Reports the best of N of each and the ratio ours / VTK (below 1: ours is faster).
On a loaded machine only the ratios mean something.

Usage:
    /work/bench/.venv/bin/python bench/vertex_removal_speed.py [--repeat N] \
        [--ratios 0.5 0.1 0.01] [--bin PATH] MESH...
"""
import argparse, json, os, subprocess, sys, tempfile, time

import vtk

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from vertex_removal_vs_vtk import decpro_timed, read_vtk  # noqa: E402  (same VTK setup)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def vtk_time(poly, ratio, preserve):
    f, dt = decpro_timed(poly, ratio, preserve)
    return dt, f.GetOutput().GetNumberOfPolys()


def ours_time(binary, path, target, out):
    r = subprocess.run([binary, "simplify", path, "-o", out, "--method", "vertex-removal",
                        "--triangles", str(target), "--json"],
                       check=True, capture_output=True, text=True).stdout
    d = json.loads(r.strip().splitlines()[-1])
    return d["seconds"], d["triangles_out"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("meshes", nargs="+")
    ap.add_argument("--ratios", nargs="+", type=float, default=[0.5, 0.1, 0.01])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--bin", default=os.path.join(ROOT, "target", "release", "meshlod"))
    a = ap.parse_args()
    out = os.path.join(tempfile.mkdtemp(), "out.ply")
    print("| mesh | ratio | VTK on: tris, s | VTK off: s | ours: tris, s | ours / VTK on | ours / VTK off |")
    print("|---|---|---|---|---|---|---|")
    for path in a.meshes:
        poly = read_vtk(path)
        n_in = poly.GetNumberOfPolys()
        for ratio in a.ratios:
            target = round(n_in * ratio)
            best = {"on": 1e9, "off": 1e9, "ours": 1e9}
            tris = {}
            for _ in range(a.repeat):
                for key in ("on", "ours", "off"):
                    if key == "ours":
                        dt, n = ours_time(a.bin, path, target, out)
                    else:
                        dt, n = vtk_time(poly, ratio, key == "on")
                    best[key] = min(best[key], dt)
                    tris[key] = n
            print(f"| {os.path.basename(path)} | {ratio} | {tris['on']}, {best['on']:.3f} | "
                  f"{best['off']:.3f} | {tris['ours']}, {best['ours']:.3f} | "
                  f"{best['ours'] / best['on']:.2f} | {best['ours'] / best['off']:.2f} |",
                  flush=True)


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env python3
"""The certified maximum of `meshlod measure` against a dense reference.

For each mesh and ratio, simplifies with `meshlod simplify --ratio R` (and, with
`--meshlab`, also with MeshLab's quadric edge collapse, which needs pymeshlab), then
measures the pair `meshlod measure ORIGINAL SIMPLIFIED --json` three ways:
  - default (certified): `max_lower`, `max_upper` of each direction, seconds;
  - `--no-certify`: the sampled maximum alone, seconds;
  - dense: `--no-certify --samples K x the default`, the reference maximum.
Prints a table per direction: the reference, the sampled and certified maxima as
ratios to it, whether the reference lies in [max_lower, max_upper], and both times.

Usage:
    cargo build --release -p meshlod-cli
    python3 bench/certified_max.py [--ratios 0.1 0.01] [--dense 20] [--meshlab] MESH...

Goal: the certified maximum within 0.5% of the dense reference on every pair, the
reference never above `max_upper`. (A certified maximum above the dense one is the
dense sampling missing the worst point, not an error.)
"""
import argparse, json, os, subprocess, sys, tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "target", "release", "meshlod")


def run(*args):
    out = subprocess.run([BIN, *args], check=True, capture_output=True, text=True).stdout
    return json.loads(out)


def triangles(path):
    return run("info", path, "--json")["triangles"]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("meshes", nargs="+")
    ap.add_argument("--ratios", type=float, nargs="+", default=[0.1, 0.01])
    ap.add_argument("--dense", type=int, default=20, help="reference samples: K x the default")
    ap.add_argument("--meshlab", action="store_true", help="also MeshLab's QEM simplifications")
    a = ap.parse_args()
    print("| pair | direction | dense max | sampled / dense | certified / dense | "
          "max_upper / dense | in interval | s sampled | s certified |")
    print("|---|---|---:|---:|---:|---:|:-:|---:|---:|")
    worst = 0.0
    with tempfile.TemporaryDirectory() as tmp:
        for path in a.meshes:
            name = os.path.basename(path)
            pairs = []
            for r in a.ratios:
                out = os.path.join(tmp, f"ours-{r}.ply")
                subprocess.run([BIN, "simplify", path, "-o", out, "--ratio", str(r)],
                               check=True, capture_output=True)
                pairs.append((f"{name} ours {r:g}", out))
                if a.meshlab:
                    import pymeshlab
                    ms = pymeshlab.MeshSet()
                    ms.load_new_mesh(path)
                    nf = ms.current_mesh().face_number()
                    ms.meshing_decimation_quadric_edge_collapse(targetfacenum=max(4, int(nf * r)))
                    out = os.path.join(tmp, f"meshlab-{r}.ply")
                    ms.save_current_mesh(out)
                    pairs.append((f"{name} MeshLab {r:g}", out))
            for label, simp in pairs:
                n = max(1_000_000, 10 * max(triangles(path), triangles(simp)))
                cert = run("measure", path, simp, "--json")
                samp = run("measure", path, simp, "--json", "--no-certify")
                dense = run("measure", path, simp, "--json", "--no-certify",
                            "--samples", str(a.dense * n))
                for side in ("a_to_b", "b_to_a"):
                    ref = dense[side]["max"]
                    lo, up = cert[side]["max_lower"], cert[side]["max_upper"]
                    inside = up is not None and ref <= up * (1 + 1e-9) + 1e-12
                    worst = max(worst, 1 - lo / ref if ref > 0 else 0.0)
                    print(f"| {label} | {side} | {ref:.6g} | {samp[side]['max'] / ref:.4f} | "
                          f"{lo / ref:.4f} | {up / ref:.4f} | {'yes' if inside else 'NO'} | "
                          f"{samp['seconds']:.2f} | {cert['seconds']:.2f} |", flush=True)
    print(f"\nlargest shortfall of the certified maximum below the dense one: {100 * worst:.3f}%")


if __name__ == "__main__":
    sys.exit(main())

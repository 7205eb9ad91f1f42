#!/usr/bin/env python3
"""meshlod terrain vs pydelatin (Fogleman's hmm) vs pymartini (Mapbox Martini).

    python bench/terrain.py [--meshlod target/release/meshlod] [--verify]
                            [--bounds 1,2,5] [--repeat 3] [--data DIR]

DIR/N57E011_3601.hgt, an SRTM-1-sized grid, is made by `bench/make_heightfield_png.py
--hgt3601` (the shared 3" tile resampled bilinearly to 3601 x 3601).

Needs numpy, Pillow, pydelatin and pymartini (a venv: `python3 -m venv tvenv &&
tvenv/bin/pip install numpy pillow pydelatin pymartini`). Height fields: the shared
Grand Canyon PNG (1200 x 1200, grey levels), the two shared SRTM-3 tiles (1201 x 1201,
metres; voids filled for the peers as meshlod fills them), and the 4097 x 2049 Grand Canyon resample (`bench/make_heightfield_png.py`,
16-bit, heights x 2 as make_terrain.py's grid meshes: --z-scale 2/256) when
DIR/gc4097x2049.png exists.

Every method gets the same heights (float32) and the same bound E (height units).
meshlod runs on one thread (RAYON_NUM_THREADS=1) like the peers, and again on two.
Times are the triangulation alone, best of --repeat: meshlod's `seconds` (reading,
measuring and writing excluded), pydelatin's constructor, pymartini's create_tile +
get_mesh. Martini needs a 2^k + 1 square grid: it runs on the 1025 x 1025 top-left
crop of the 1200/1201 fields (marked `crop`; meshlod and pydelatin run on the same
crop in that row) and on the two 2049 x 2049 halves of the 4097 x 2049 grid (summed).
--verify measures each peer's TIN against every grid sample (slow, pure numpy).
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
from PIL import Image

HERE = os.path.dirname(os.path.abspath(__file__))
SHARED = os.path.normpath(os.path.join(HERE, "..", "..", "shared", "meshes"))


def load(path, z_scale):
    if path.endswith(".hgt"):
        a = np.fromfile(path, dtype=">i2").astype(np.float32)
        n = int(round(len(a) ** 0.5))
        a = a.reshape(n, n)
        return fill_voids(a, a == -32768)
    return np.asarray(Image.open(path)).astype(np.float32) * np.float32(z_scale)


def fill_voids(a, void):
    """meshlod's void filling (heightfield.rs), for the peers: layer by layer, each
    void touching a valid sample takes the mean of its valid 8-neighbours."""
    a = a.astype(np.float64)
    a[void] = np.nan
    while np.isnan(a).any():
        p = np.pad(a, 1, constant_values=np.nan)
        s = np.zeros_like(a); k = np.zeros_like(a)
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                if dy == 0 and dx == 0:
                    continue
                n = p[1 + dy:1 + dy + a.shape[0], 1 + dx:1 + dx + a.shape[1]]
                ok = ~np.isnan(n)
                s[ok] += n[ok]; k[ok] += 1
        layer = np.isnan(a) & (k > 0)
        if not layer.any():
            raise SystemExit("every sample is void")
        a[layer] = s[layer] / k[layer]
    return a.astype(np.float32)


def write_hgt_like(a, path):
    """Writes a float32 grid meshlod reads exactly: a 16-bit PNG when integral."""
    Image.fromarray(a.astype(np.uint16)).save(path)


def run_meshlod(exe, path, E, z_scale, repeat, extra=(), threads=1):
    best = None
    env = dict(os.environ, RAYON_NUM_THREADS=str(threads))
    for _ in range(repeat):
        with tempfile.TemporaryDirectory() as d:
            out = subprocess.run(
                [exe, "terrain", path, "-o", os.path.join(d, "t.ply"), "--max-error",
                 str(E), "--z-scale", repr(z_scale), "--json", *extra],
                check=True, capture_output=True, text=True, env=env).stdout
        r = json.loads(out)
        if best is None or r["seconds"] < best["seconds"]:
            best = r
    return best


def run_delatin(a, E, repeat):
    from pydelatin import Delatin
    best = None
    for _ in range(repeat):
        t = time.perf_counter()
        tin = Delatin(a, height=a.shape[0], width=a.shape[1], max_error=E)
        dt = time.perf_counter() - t
        if best is None or dt < best[0]:
            best = (dt, tin.vertices, tin.triangles)
    return best


def run_martini(a, E, repeat):
    """Martini on square 2^k + 1 blocks of `a` (one, or the two halves of 4097 x 2049)."""
    from pymartini import Martini
    n = a.shape[0]
    blocks = [a] if a.shape[1] == n else [a[:, :n], a[:, n - 1:]]
    best = None
    for _ in range(repeat):
        total, tris, verts = 0.0, [], []
        for k, b in enumerate(blocks):
            t = time.perf_counter()
            m = Martini(n)
            tile = m.create_tile(np.ascontiguousarray(b, dtype=np.float32).ravel())
            v, f = tile.get_mesh(E)
            total += time.perf_counter() - t
            v = v.reshape(-1, 2).astype(np.int64)
            v[:, 0] += k * (n - 1)
            verts.append(v)
            tris.append(f.reshape(-1, 3))
        if best is None or total < best[0]:
            best = (total, verts, tris)
    return best


def max_error(a, verts, tris):
    """Largest |height − TIN| over every sample covered (numpy, triangle by triangle)."""
    worst = 0.0
    for v, f in zip(verts, tris):
        v = np.asarray(v).reshape(-1, 2).astype(np.int64)
        z = a[v[:, 1], v[:, 0]].astype(np.float64)
        for t in np.asarray(f).reshape(-1, 3):
            (x0, y0), (x1, y1), (x2, y2) = v[t[0]], v[t[1]], v[t[2]]
            det = (x1 - x0) * (y2 - y0) - (y1 - y0) * (x2 - x0)
            if det == 0:
                continue
            xs = np.arange(min(x0, x1, x2), max(x0, x1, x2) + 1)
            ys = np.arange(min(y0, y1, y2), max(y0, y1, y2) + 1)
            X, Y = np.meshgrid(xs, ys)
            w0 = ((x1 - X) * (y2 - Y) - (y1 - Y) * (x2 - X)) / det
            w1 = ((x2 - X) * (y0 - Y) - (y2 - Y) * (x0 - X)) / det
            w2 = 1 - w0 - w1
            inside = (w0 >= -1e-12) & (w1 >= -1e-12) & (w2 >= -1e-12)
            if not inside.any():
                continue
            zi = w0 * z[t[0]] + w1 * z[t[1]] + w2 * z[t[2]]
            d = np.abs(a[Y, X].astype(np.float64) - zi)[inside]
            worst = max(worst, float(d.max()))
    return worst


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--meshlod", default=os.path.join(HERE, "..", "target", "release", "meshlod"))
    ap.add_argument("--bounds", default="1,2,5")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--data", default="/work/data/terrain")
    ap.add_argument("--verify", action="store_true")
    a = ap.parse_args()
    bounds = [float(b) for b in a.bounds.split(",")]
    fields = [
        ("gcanyon 1200^2 (grey)", os.path.join(SHARED, "hoppe-mesh-processing-library", "gcanyon_elev_crop.bw.png"), 1.0),
        ("N40W074.hgt (m)", os.path.join(SHARED, "srtm", "N40W074.hgt"), 1.0),
        ("N57E011.hgt (m)", os.path.join(SHARED, "srtm", "N57E011.hgt"), 1.0),
        ("gcanyon 4097x2049 (grey x 2)", os.path.join(a.data, "gc4097x2049.png"), 2.0 / 256),
        ("N57E011 resampled 3601^2 (m)", os.path.join(a.data, "N57E011_3601.hgt"), 1.0),
    ]
    print(f"# {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, meshlod {a.meshlod}")
    print("| height field | E | meshlod tris | meshlod s | meshlod s, 2 threads | --no-prune tris | --no-prune s | pydelatin tris | pydelatin s | pymartini tris | pymartini s | meshlod max err | meshlod B/sample |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    tmp = tempfile.mkdtemp()
    for name, path, zs in fields:
        if not os.path.exists(path):
            print(f"skipping {name}: {path} is absent", file=sys.stderr)
            continue
        grid = load(path, zs)
        runs = [(name, path, zs, grid)]
        if grid.shape[0] not in (2049, 3601):
            crop = np.ascontiguousarray(grid[:1025, :1025])
            cpath = os.path.join(tmp, os.path.basename(path) + ".crop.png")
            write_hgt_like(crop - crop.min(), cpath)  # metres, shifted to >= 0
            runs = [(name, path, zs, grid), (name + " crop 1025^2", cpath, 1.0, crop - crop.min())]
        for label, p, z, g in runs:
            for E in bounds:
                m = run_meshlod(a.meshlod, p, E, z, a.repeat)
                q = run_meshlod(a.meshlod, p, E, z, a.repeat, ["--no-prune"])
                m2 = run_meshlod(a.meshlod, p, E, z, a.repeat, threads=2)
                dt, dv, df = run_delatin(g, E, a.repeat)
                square = g.shape[0] in (1025, 2049) and g.shape[1] in (g.shape[0], 2 * g.shape[0] - 1)
                mt = run_martini(g, E, a.repeat) if square else None
                mcell = f"{sum(len(t) for t in mt[2])} | {mt[0]:.3f}" if mt else "– | –"
                nd = len(df) // 3 if df.ndim == 1 else len(df)
                bps = m.get("peak_rss_bytes_per_sample") or float("nan")
                print(f"| {label} | {E:g} | {m['triangles']} | {m['seconds']:.3f} | {m2['seconds']:.3f} | {q['triangles']} | {q['seconds']:.3f} | {nd} | {dt:.3f} | {mcell} | {m['max_error']:.4f} | {bps:.1f} |", flush=True)
                if a.verify:
                    de = max_error(g, [dv], [df])
                    me = max_error(g, mt[1], mt[2]) if mt else float("nan")
                    print(f"| verified max error | | | | | | | {de:.4f} | | {me:.4f} | | | |", flush=True)


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Resample a greyscale height image bilinearly to W x H samples as a 16-bit PNG.

    make_heightfield_png.py IN.png OUT.png --width 4097 --height 2049

The same bilinear resampling as ../shared/tools/make_terrain.py (which writes a grid
PLY instead): the 16-bit value is round(grey x 256), so `meshlod terrain OUT.png
--z-scale 0.0078125` (2/256) gives the heights of `make_terrain.py ... --z-scale 2`
to within 1/512 of a grey level. Needs numpy and Pillow.

    make_heightfield_png.py IN.hgt OUT.hgt --hgt3601

resamples an SRTM-3 tile (1201 x 1201) to the SRTM-1 size, 3601 x 3601, as an .hgt
(voids, none in the shared tiles, are not treated).
"""
import argparse
import numpy as np
from PIL import Image

ap = argparse.ArgumentParser()
ap.add_argument("image"); ap.add_argument("out")
ap.add_argument("--width", type=int); ap.add_argument("--height", type=int)
ap.add_argument("--hgt3601", action="store_true")
a = ap.parse_args()
if a.hgt3601:
    a.width = a.height = 3601
    im = np.fromfile(a.image, dtype=">i2").astype(np.float64).reshape(1201, 1201)
else:
    im = np.asarray(Image.open(a.image).convert("F"), dtype=np.float64)
H, W = (a.height or im.shape[0]), (a.width or im.shape[1])
ys = np.linspace(0, im.shape[0] - 1, H); xs = np.linspace(0, im.shape[1] - 1, W)
y0 = np.floor(ys).astype(int); x0 = np.floor(xs).astype(int)
y1 = np.minimum(y0 + 1, im.shape[0] - 1); x1 = np.minimum(x0 + 1, im.shape[1] - 1)
fy = (ys - y0)[:, None]; fx = (xs - x0)[None, :]
z = (im[y0][:, x0] * (1 - fy) * (1 - fx) + im[y0][:, x1] * (1 - fy) * fx
     + im[y1][:, x0] * fy * (1 - fx) + im[y1][:, x1] * fy * fx)
if a.hgt3601:
    np.rint(z).astype(">i2").tofile(a.out)
    print(f"{a.out}: {W} x {H} samples, SRTM-1 size")
    raise SystemExit
q = np.clip(np.rint(z * 256), 0, 65535).astype(np.uint16)
Image.fromarray(q).save(a.out)
print(f"{a.out}: {W} x {H} samples, 16-bit")

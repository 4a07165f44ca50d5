"""One line on a `meshrad solve` output folder: the total image's mean (EXR, linear), the
share of its pixels at or above 1 in some channel (white at `--exposure 0`), the share of
saturated PNG pixels (some channel at 255, after the exposure the run applied), and the
emitting triangles (stats.json). Usage: python3 image_stats.py OUT_DIR TAG WALL_S"""
import json
import sys

import Imath
import numpy as np
import OpenEXR
from PIL import Image

d, tag, wall = sys.argv[1:]
f = OpenEXR.InputFile(f"{d}/total.exr")
rgb = np.stack([np.frombuffer(f.channel(c, Imath.PixelType(Imath.PixelType.FLOAT)), np.float32) for c in "RGB"], 1)
png = np.asarray(Image.open(f"{d}/total.png").convert("RGB"))
st = json.load(open(f"{d}/stats.json"))
print(
    f"{tag}: mean EXR {rgb.mean():.5f}, EXR pixels >= 1 {100 * (rgb.max(axis=1) >= 1).mean():.2f} %, "
    f"saturated PNG pixels {100 * (png.max(axis=2) == 255).mean():.2f} %, "
    f"emitting triangles {st['scene']['load']['emitting_triangles']}, wall {float(wall):.1f} s"
)

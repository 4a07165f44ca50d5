#!/usr/bin/env python3
"""Issue #33: the error of an image against a converged reference image, over all pixels
and away from edges, with the reference's own noise taken out.

Usage: image_error.py REF_A.exr REF_B.exr IMAGE.exr [IMAGE.exr ...]

REF_A and REF_B are two independent references (`meshrad reference --camera` with two
seeds). Their mean is the reference; half their difference estimates its noise per pixel,
and the noise's mean square is subtracted from the squared error (the same convention as
the issue: "with the reference's own noise taken out"). Relative RMS = sqrt(mean((img -
ref)^2) - noise^2) / mean(ref), per channel pooled, over:
  all     every pixel, edges included;
  smooth  pixels none of whose 4 neighbours differs from it by more than 10 % of the
          larger luminance (plus 1 % of the mean) in the reference: away from silhouettes
          and shadow edges.
"""
import sys

import numpy as np
import OpenEXR


def read(path):
    with OpenEXR.File(path) as f:
        ch = f.channels()
        if "RGB" in ch:
            return np.asarray(ch["RGB"].pixels, dtype=np.float64)
        return np.stack([np.asarray(ch[c].pixels, dtype=np.float64) for c in "RGB"], -1)


def smooth_mask(ref):
    y = ref @ np.array([0.2126, 0.7152, 0.0722])
    floor = 0.01 * y.mean()
    edge = np.zeros(y.shape, bool)
    for axis in (0, 1):
        d = np.abs(np.diff(y, axis=axis))
        big = d > 0.1 * np.maximum(np.delete(y, 0, axis), np.delete(y, -1, axis)) + floor
        if axis == 0:
            edge[1:] |= big
            edge[:-1] |= big
        else:
            edge[:, 1:] |= big
            edge[:, :-1] |= big
    return ~edge


def main():
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    a, b = read(sys.argv[1]), read(sys.argv[2])
    ref = 0.5 * (a + b)
    noise2 = 0.25 * (a - b) ** 2  # the variance of the mean of two, per pixel
    mask = smooth_mask(ref)
    print(f"reference noise: all {np.sqrt(noise2.mean()) / ref.mean() * 100:.2f} %, "
          f"smooth pixels {mask.sum()} of {mask.size}")
    for path in sys.argv[3:]:
        img = read(path)
        out = []
        for name, m in (("all", np.ones(mask.shape, bool)), ("smooth", mask)):
            e2 = ((img - ref) ** 2)[m].mean() - noise2[m].mean()
            rel = np.sqrt(max(e2, 0.0)) / ref[m].mean() * 100
            bias = img[m].mean() / ref[m].mean()
            out.append(f"{name} {rel:.2f} % (energy {bias:.4f})")
        print(f"{path}: " + "; ".join(out))


if __name__ == "__main__":
    main()

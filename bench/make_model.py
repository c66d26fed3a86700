#!/usr/bin/env python3
"""Write a binary STL of a twisted, lobed vase-shaped solid for slicer benchmarks.

The solid is watertight: a side wall whose cross-section is a five-lobed
rounded star that bulges in the middle and twists 90 degrees from bottom to
top, closed by a flat bottom and a flat top. About 60 x 60 x 60 mm, standing
on z = 0, centred on x = y = 0 (the slicer centres it on the bed).

Standard library only. Usage: python3 make_model.py [OUT.stl]
"""

import math
import struct
import sys

HEIGHT = 60.0  # mm
N_THETA = 240  # facets around
N_Z = 150  # rings up the side (0.4 mm apart)
LOBES = 5
TWIST = math.pi / 2  # total twist bottom to top


def radius(theta, z):
    """Outline radius at angle theta and height z (mm)."""
    t = z / HEIGHT
    base = 22.0 + 6.0 * math.sin(math.pi * t) - 2.0 * t  # bulge, slight taper
    lobe = 0.11 * math.cos(LOBES * (theta - TWIST * t))
    return base * (1.0 + lobe)


def ring(k):
    z = HEIGHT * k / N_Z
    pts = []
    for i in range(N_THETA):
        th = 2.0 * math.pi * i / N_THETA
        r = radius(th, z)
        pts.append((r * math.cos(th), r * math.sin(th), z))
    return pts


def normal(a, b, c):
    u = [b[i] - a[i] for i in range(3)]
    v = [c[i] - a[i] for i in range(3)]
    n = (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])
    length = math.sqrt(sum(x * x for x in n)) or 1.0
    return tuple(x / length for x in n)


def triangles():
    rings = [ring(k) for k in range(N_Z + 1)]
    # side wall: counter-clockwise seen from outside
    for k in range(N_Z):
        lo, hi = rings[k], rings[k + 1]
        for i in range(N_THETA):
            j = (i + 1) % N_THETA
            yield lo[i], lo[j], hi[j]
            yield lo[i], hi[j], hi[i]
    # bottom cap (normal down) and top cap (normal up): fans from the centre
    bottom, top = rings[0], rings[N_Z]
    cb, ct = (0.0, 0.0, 0.0), (0.0, 0.0, HEIGHT)
    for i in range(N_THETA):
        j = (i + 1) % N_THETA
        yield cb, bottom[j], bottom[i]
        yield ct, top[i], top[j]


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "twisted-vase.stl"
    tris = list(triangles())
    with open(out, "wb") as f:
        f.write(b"motet bench: twisted lobed vase".ljust(80, b" "))
        f.write(struct.pack("<I", len(tris)))
        for a, b, c in tris:
            f.write(struct.pack("<3f", *normal(a, b, c)))
            for p in (a, b, c):
                f.write(struct.pack("<3f", *p))
            f.write(b"\0\0")
    print(f"wrote {out}: {len(tris)} triangles")


if __name__ == "__main__":
    main()

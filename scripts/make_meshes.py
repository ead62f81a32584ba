#!/usr/bin/env python3
"""Writes the triangle meshes of the example equipment (scenes/meshes/, docs/equipment.md) as
ASCII STL, with the standard library only.

    python3 scripts/make_meshes.py                  # the default set into scenes/meshes/
    python3 scripts/make_meshes.py silo --orifice 0.012 --out scenes/meshes/silo_D12.stl

Meshes (units: m; z up). Triangles are two-sided in clatter and any winding is accepted; these
follow the STL convention anyway: the closed drum is wound counter-clockwise seen from outside
(facet normals out), the open silo and plate face the bodies (normals into the silo, the
plate's up). Neighbouring triangles meet vertex to vertex (no T-junctions, which clatter would
split and warn about).

- silo: a flat-bottomed square silo, side `width`, walls `height` high, standing on z = 0,
  centred on the z axis, with a central square orifice of side `orifice` in its floor.
- plate: a square plate of side `size` at height `z`, facing up: it closes the orifice from
  below until it slides away (the scene's `motion` with a `start` time).
- drum: a closed cylinder of radius `radius` and length `length` around the y axis, centred
  at the origin, with its two end caps, `segments` facets around.
"""

import argparse
import math
import os
import sys


def quad(a, b, c, d):
    """Two triangles of the planar quad a-b-c-d (counter-clockwise seen from its front)."""
    return [(a, b, c), (a, c, d)]


def normal(t):
    (ax, ay, az), (bx, by, bz), (cx, cy, cz) = t
    ux, uy, uz = bx - ax, by - ay, bz - az
    vx, vy, vz = cx - ax, cy - ay, cz - az
    n = (uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx)
    length = math.sqrt(sum(x * x for x in n))
    return tuple(x / length for x in n)


def silo(width, height, orifice):
    """Floor with a square hole (eight quads around it) and four inward-facing walls, each in
    three columns: the floor's and the walls' edges meet vertex to vertex (no T-junctions)."""
    if not 0 < orifice < width:
        raise ValueError(f"the orifice ({orifice}) must be narrower than the silo ({width})")
    w, o = width / 2, orifice / 2
    c = [-w, -o, o, w]
    h = height
    tris = []
    # Floor at z = 0, facing up: the 3 x 3 grid of cells on c x c, less the middle one.
    for j in range(3):
        for i in range(3):
            if (i, j) != (1, 1):
                tris += quad((c[i], c[j], 0), (c[i + 1], c[j], 0), (c[i + 1], c[j + 1], 0), (c[i], c[j + 1], 0))
    # Walls facing inwards, split at the orifice's lines like the floor's edges.
    for k in range(3):
        a, b = c[k], c[k + 1]
        tris += quad((-w, a, 0), (-w, b, 0), (-w, b, h), (-w, a, h))  # x = -w, normal +x
        tris += quad((w, b, 0), (w, a, 0), (w, a, h), (w, b, h))  # x = +w, normal -x
        tris += quad((b, -w, 0), (a, -w, 0), (a, -w, h), (b, -w, h))  # y = -w, normal +y
        tris += quad((a, w, 0), (b, w, 0), (b, w, h), (a, w, h))  # y = +w, normal -y
    return tris


def plate(size, z):
    """A square facing up at height z."""
    s = size / 2
    return quad((-s, -s, z), (s, -s, z), (s, s, z), (-s, s, z))


def drum(radius, length, segments):
    """Mantle and end caps of a cylinder around the y axis, wound outwards (closed mesh)."""
    tris = []
    y0, y1 = -length / 2, length / 2
    ring = [
        (radius * math.cos(2 * math.pi * k / segments), radius * math.sin(2 * math.pi * k / segments))
        for k in range(segments)
    ]
    for k in range(segments):
        (x0, z0), (x1, z1) = ring[k], ring[(k + 1) % segments]
        # Mantle, normal away from the axis.
        tris += quad((x0, y0, z0), (x0, y1, z0), (x1, y1, z1), (x1, y0, z1))
        # Caps: y = y0 faces -y, y = y1 faces +y.
        tris.append(((0, y0, 0), (x0, y0, z0), (x1, y0, z1)))
        tris.append(((0, y1, 0), (x1, y1, z1), (x0, y1, z0)))
    return tris


def write_stl(path, name, tris):
    os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
    with open(path, "w") as f:
        f.write(f"solid {name}\n")
        for t in tris:
            n = normal(t)
            f.write(f"  facet normal {n[0]:.9g} {n[1]:.9g} {n[2]:.9g}\n    outer loop\n")
            for v in t:
                f.write(f"      vertex {v[0]:.9g} {v[1]:.9g} {v[2]:.9g}\n")
            f.write("    endloop\n  endfacet\n")
        f.write(f"endsolid {name}\n")


# The default set: the hopper's silo and plate, and the drum (docs/equipment.md).
DEFAULTS = {
    "hopper_silo.stl": lambda: silo(width=0.05, height=0.12, orifice=0.02),
    "bench_silo.stl": lambda: silo(width=0.2, height=0.25, orifice=0.03),
    "hopper_plate.stl": lambda: plate(size=0.03, z=-0.001),
    "drum.stl": lambda: drum(radius=0.05, length=0.03, segments=48),
}


def main(argv):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="kind")
    s = sub.add_parser("silo")
    s.add_argument("--width", type=float, default=0.05)
    s.add_argument("--height", type=float, default=0.12)
    s.add_argument("--orifice", type=float, default=0.02)
    s.add_argument("--out", required=True)
    pl = sub.add_parser("plate")
    pl.add_argument("--size", type=float, default=0.03)
    pl.add_argument("--z", type=float, default=-0.001)
    pl.add_argument("--out", required=True)
    d = sub.add_parser("drum")
    d.add_argument("--radius", type=float, default=0.05)
    d.add_argument("--length", type=float, default=0.03)
    d.add_argument("--segments", type=int, default=48)
    d.add_argument("--out", required=True)
    a = p.parse_args(argv)
    if a.kind is None:
        here = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scenes", "meshes")
        for name, make in DEFAULTS.items():
            write_stl(os.path.join(here, name), name[:-4], make())
            print(os.path.normpath(os.path.join(here, name)))
        return
    if a.kind == "silo":
        tris = silo(a.width, a.height, a.orifice)
    elif a.kind == "plate":
        tris = plate(a.size, a.z)
    else:
        tris = drum(a.radius, a.length, a.segments)
    write_stl(a.out, a.kind, tris)


if __name__ == "__main__":
    main(sys.argv[1:])

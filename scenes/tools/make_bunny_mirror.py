#!/usr/bin/env python3
"""Generates scenes/bunny-mirror/bunny-mirror.glb: the Stanford bunny (scaled to 0.3 m)
standing on a mirror floor in a small closed room with coloured diffuse walls and an
emissive ceiling light.

Pure Python 3 standard library; deterministic (the same bytes on every run).
Units: metres, +Y up, right-handed (glTF). The room spans x ∈ [-1.5, 1.5],
y ∈ [0, 2.2], z ∈ [-1.5, 1.5]; the bunny stands at the origin.

Usage: python3 scenes/tools/make_bunny_mirror.py [--out PATH]
"""

import os
import sys

sys.dont_write_bytecode = True  # keep scenes/tools free of __pycache__
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from glbtools import drop_degenerate, generator_main, Geometry, GlbWriter, read_glb_mesh  # noqa: E402

SCENE_DIR = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "bunny-mirror")
BUNNY_GLB = os.path.join(SCENE_DIR, "source", "bunny.glb")

X0, X1 = -1.5, 1.5
Y0, Y1 = 0.0, 2.2
Z0, Z1 = -1.5, 1.5

BUNNY_HEIGHT = 0.3


def build():
    w = GlbWriter(
        "glint scenes/tools/make_bunny_mirror.py",
        "glint bunny-mirror; Stanford Bunny, Stanford University Computer Graphics Laboratory "
        "(Stanford 3D Scanning Repository), decimated mesh from npm 'bunny' 1.0.1 by Mikola Lysenko",
    )
    w.material("Mirror", (0.95, 0.95, 0.95), 1.0, 0.02)
    w.material("WallBlue", (0.25, 0.35, 0.60))
    w.material("WallCream", (0.75, 0.72, 0.62))
    w.material("WallRed", (0.65, 0.12, 0.10))
    w.material("WallGreen", (0.15, 0.48, 0.12))
    w.material("CeilingWhite", (0.80, 0.80, 0.80))
    w.material("BunnyClay", (0.78, 0.62, 0.50), 0.0, 0.7)
    w.material("CeilingLight", (0.80, 0.80, 0.80), 0.0, 1.0, (1.0, 0.97, 0.9), 16.0)

    dx, dy, dz = X1 - X0, Y1 - Y0, Z1 - Z0
    # The whole floor is the mirror; walls and ceiling are single quads facing into the room.
    w.mesh("MirrorFloor", Geometry().quad((X0, Y0, Z1), (dx, 0, 0), (0, 0, -dz)), "Mirror")
    w.mesh("Ceiling", Geometry().quad((X0, Y1, Z0), (dx, 0, 0), (0, 0, dz)), "CeilingWhite")
    w.mesh("WallN", Geometry().quad((X0, Y0, Z0), (dx, 0, 0), (0, dy, 0)), "WallBlue")
    w.mesh("WallS", Geometry().quad((X1, Y0, Z1), (-dx, 0, 0), (0, dy, 0)), "WallCream")
    w.mesh("WallE", Geometry().quad((X1, Y0, Z0), (0, 0, dz), (0, dy, 0)), "WallGreen")
    w.mesh("WallW", Geometry().quad((X0, Y0, Z1), (0, 0, -dz), (0, dy, 0)), "WallRed")

    # Stanford bunny: scaled to BUNNY_HEIGHT, its lowest point on the floor, centred in x and z.
    positions, normals, indices = read_glb_mesh(BUNNY_GLB)
    lo = [min(p[i] for p in positions) for i in range(3)]
    hi = [max(p[i] for p in positions) for i in range(3)]
    scale = BUNNY_HEIGHT / (hi[1] - lo[1])
    cx, cz = (lo[0] + hi[0]) / 2, (lo[2] + hi[2]) / 2
    bunny = Geometry()
    bunny.positions = [((p[0] - cx) * scale, (p[1] - lo[1]) * scale + Y0, (p[2] - cz) * scale) for p in positions]
    bunny.normals = list(normals)
    bunny.indices = drop_degenerate(bunny.positions, list(indices))
    w.mesh("Bunny", bunny, "BunnyClay")

    # Ceiling light: 0.8 × 0.8 m, 2 cm below the ceiling, above the bunny, facing down.
    w.mesh("CeilingLight", Geometry().quad((-0.4, Y1 - 0.02, -0.4), (0.8, 0, 0), (0, 0, 0.8)), "CeilingLight")
    return w.to_bytes()


if __name__ == "__main__":
    generator_main(__doc__, os.path.join(SCENE_DIR, "bunny-mirror.glb"), build)

#!/usr/bin/env python3
"""Generates scenes/glossy-room/glossy-room.glb: a closed 6 × 3 × 5 m room with a glossy
floor, a near-mirror wall panel, a table with a glossy top, a polished-metal Utah teapot on
it and an emissive ceiling light.

Pure Python 3 standard library; deterministic (the same bytes on every run).
Units: metres, +Y up, right-handed (glTF). The room spans x ∈ [-3, 3], y ∈ [0, 3],
z ∈ [-2.5, 2.5]; "north" is −Z (where the default cameras look).

Usage: python3 scenes/tools/make_glossy_room.py [--out PATH]
"""

import os
import sys

sys.dont_write_bytecode = True  # keep scenes/tools free of __pycache__
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from glbtools import drop_degenerate, generator_main, Geometry, GlbWriter, read_glb_mesh  # noqa: E402

SCENE_DIR = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "glossy-room")
TEAPOT_GLB = os.path.join(SCENE_DIR, "source", "teapot.glb")

# Room bounds (metres).
X0, X1 = -3.0, 3.0
Y0, Y1 = 0.0, 3.0
Z0, Z1 = -2.5, 2.5

# Table: top surface at TABLE_Y, centred on (TABLE_X, TABLE_Z).
TABLE_X, TABLE_Z = 0.0, -0.3
TABLE_HALF_X, TABLE_HALF_Z = 0.7, 0.4
TABLE_Y = 0.75
TABLE_THICKNESS = 0.04
LEG = 0.05  # square leg side
LEG_INSET = 0.08  # leg centre from the top's edges

TEAPOT_HEIGHT = 0.3


def build():
    w = GlbWriter(
        "glint scenes/tools/make_glossy_room.py",
        "glint glossy-room; Utah teapot by Martin Newell (1975), public domain",
    )
    w.material("Plaster", (0.72, 0.70, 0.66))
    w.material("AccentWall", (0.62, 0.32, 0.22))
    w.material("CeilingWhite", (0.80, 0.80, 0.80))
    # glTF roughness 0.3162 maps to Beckmann m = 0.1; scene.json also sets the lobe explicitly.
    w.material("GlossyFloor", (0.40, 0.40, 0.40), 0.0, 0.3162)
    w.material("Mirror", (0.95, 0.95, 0.95), 1.0, 0.01)
    # glTF roughness 0.3873 maps to Beckmann m = 0.15.
    w.material("GlossyTable", (0.35, 0.20, 0.10), 0.0, 0.3873)
    w.material("TableWood", (0.30, 0.18, 0.09), 0.0, 0.8)
    w.material("PolishedMetal", (0.95, 0.64, 0.54), 1.0, 0.1)
    w.material("CeilingLight", (0.80, 0.80, 0.80), 0.0, 1.0, (1.0, 0.95, 0.85), 20.0)

    dx, dy, dz = X1 - X0, Y1 - Y0, Z1 - Z0
    # Walls, floor and ceiling: one quad each, facing into the room.
    w.mesh("Floor", Geometry().quad((X0, Y0, Z1), (dx, 0, 0), (0, 0, -dz)), "GlossyFloor")
    w.mesh("Ceiling", Geometry().quad((X0, Y1, Z0), (dx, 0, 0), (0, 0, dz)), "CeilingWhite")
    w.mesh("WallN", Geometry().quad((X0, Y0, Z0), (dx, 0, 0), (0, dy, 0)), "Plaster")
    w.mesh("WallS", Geometry().quad((X1, Y0, Z1), (-dx, 0, 0), (0, dy, 0)), "Plaster")
    w.mesh("WallE", Geometry().quad((X1, Y0, Z0), (0, 0, dz), (0, dy, 0)), "AccentWall")
    w.mesh("WallW", Geometry().quad((X0, Y0, Z1), (0, 0, -dz), (0, dy, 0)), "Plaster")

    # Near-mirror panel 3 cm in front of the north wall, 2.5 × 2 m, facing +Z.
    w.mesh("MirrorPanel", Geometry().quad((-1.25, 0.4, Z0 + 0.03), (2.5, 0, 0), (0, 2.0, 0)), "Mirror")

    # Table: the top face alone is `TableTop` (planar); the slab's sides and underside and the
    # legs are separate meshes.
    tx0, tx1 = TABLE_X - TABLE_HALF_X, TABLE_X + TABLE_HALF_X
    tz0, tz1 = TABLE_Z - TABLE_HALF_Z, TABLE_Z + TABLE_HALF_Z
    w.mesh("TableTop", Geometry().quad((tx0, TABLE_Y, tz1), (tx1 - tx0, 0, 0), (0, 0, tz0 - tz1)), "GlossyTable")
    under = TABLE_Y - TABLE_THICKNESS
    w.mesh("TableEdge", Geometry().box((tx0, under, tz0), (tx1, TABLE_Y, tz1), "+x-x-y+z-z"), "TableWood")
    legs = Geometry()
    for lx in (tx0 + LEG_INSET, tx1 - LEG_INSET):
        for lz in (tz0 + LEG_INSET, tz1 - LEG_INSET):
            h = LEG / 2
            legs.box((lx - h, Y0, lz - h), (lx + h, under, lz + h), "+x-x+z-z")
    w.mesh("TableLegs", legs, "TableWood")

    # Utah teapot, scaled to TEAPOT_HEIGHT and standing on the table's centre.
    positions, normals, indices = read_glb_mesh(TEAPOT_GLB)
    ys = [p[1] for p in positions]
    scale = TEAPOT_HEIGHT / (max(ys) - min(ys))
    lift = TABLE_Y - min(ys) * scale
    teapot = Geometry()
    teapot.positions = [(p[0] * scale + TABLE_X, p[1] * scale + lift, p[2] * scale + TABLE_Z) for p in positions]
    teapot.normals = list(normals)
    teapot.indices = drop_degenerate(teapot.positions, list(indices))
    w.mesh("Teapot", teapot, "PolishedMetal")

    # Ceiling light: 1 × 1 m, 2 cm below the ceiling, above the table, facing down.
    w.mesh(
        "CeilingLight",
        Geometry().quad((TABLE_X - 0.5, Y1 - 0.02, TABLE_Z - 0.5), (1.0, 0, 0), (0, 0, 1.0)),
        "CeilingLight",
    )
    return w.to_bytes()


if __name__ == "__main__":
    generator_main(__doc__, os.path.join(SCENE_DIR, "glossy-room.glb"), build)

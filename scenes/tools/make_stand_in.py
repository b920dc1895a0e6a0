#!/usr/bin/env python3
"""Generates scenes/stand-in/stand-in.glb: a small bathroom with what downloaded interiors have.

A 4 × 2.6 × 4 m room (x, z in [-2, 2], y in [0, 2.6], inward faces) lit by an emissive ceiling
panel. Its west part (x < 0.4) has a glossy floor of small hexagonal tiles (a fine, mipmapped
base colour texture, repeated 32 × 32 times) and a glossy wooden vanity (a wood-grain texture)
against the -Z wall: glossy textured surfaces that no reflector declares, so the bake gives each
a reflection probe. A glass jar (KHR_materials_transmission 0.9, KHR_materials_ior 1.5) with a
red soap bar inside stands on the vanity. The east part (x > 0.4) is a mirror floor (metallic,
roughness 0.02: scene.json declares it a planar reflector) with a column standing on it.
Every texture is generated here (PNG, in the binary chunk). Deterministic: the same bytes on
every run.
"""

import math
import os

from glbtools import generator_main, Geometry, GlbWriter, png_bytes

SCENE_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "stand-in")

X0, X1, Y0, Y1, Z0, Z1 = -2.0, 2.0, 0.0, 2.6, -2.0, 2.0
# Where the tiled floor ends and the mirror floor begins.
XM = 0.4

# The hexagon lattice's period in texels: two hexagons across 32, one row pair down 56 (≈ √3·32).
HEX_W, HEX_H = 32, 56


def hex_tiles(x, y):
    """32 × 56: hexagonal tiles (a centred rectangular lattice's Voronoi cells) in two shades of
    grey-green, the corner cells' and the centre cell's, separated by dark grout about 2 texels
    wide; it tiles seamlessly."""
    px, py = x + 0.5, y + 0.5
    corners = [(0, 0), (HEX_W, 0), (0, HEX_H), (HEX_W, HEX_H)]
    dists = sorted([(math.hypot(px - cx, py - cy), 0) for cx, cy in corners] + [(math.hypot(px - HEX_W / 2, py - HEX_H / 2), 1)])
    if dists[1][0] - dists[0][0] < 2.2:
        return (48, 46, 42, 255)
    shades = ((186, 196, 188), (150, 168, 160))
    return shades[dists[0][1]] + (255,)


def wood(x, y):
    """64 × 64: walnut-like grain running along x (rings bent by a slow wave)."""
    ring = math.sin((y + 3.0 * math.sin(x / 9.0) + 1.5 * math.sin(x / 3.7)) * 0.9)
    t = 0.5 + 0.5 * ring
    return (int(92 + 40 * t), int(58 + 24 * t), int(34 + 12 * t), 255)


def column(geometry, cx, cz, radius, height, sides=12):
    """An upright prism of `sides` faces (outward) with a top cap, standing on y = 0."""
    for i in range(sides):
        a0 = 2 * math.pi * i / sides
        a1 = 2 * math.pi * (i + 1) / sides
        p0 = (cx + radius * math.cos(a0), 0.0, cz - radius * math.sin(a0))
        p1 = (cx + radius * math.cos(a1), 0.0, cz - radius * math.sin(a1))
        geometry.quad(p0, (p1[0] - p0[0], 0.0, p1[2] - p0[2]), (0.0, height, 0.0))
        centre = (cx, height, cz)
        base = len(geometry.positions)
        geometry.positions += [centre, (p0[0], height, p0[2]), (p1[0], height, p1[2])]
        geometry.normals += [(0.0, 1.0, 0.0)] * 3
        geometry.indices += [base, base + 1, base + 2]
    return geometry


def build():
    w = GlbWriter("glint scenes/tools/make_stand_in.py")
    tiles_tex = w.texture_png(png_bytes(HEX_W, HEX_H, hex_tiles))
    wood_tex = w.texture_png(png_bytes(64, 64, wood))

    w.material("Tiles", (1.0, 1.0, 1.0), roughness=0.35, base_texture=tiles_tex)
    w.material("Vanity", (1.0, 1.0, 1.0), roughness=0.3, base_texture=wood_tex)
    w.material("Mirror", (0.95, 0.95, 0.95), metallic=1.0, roughness=0.02)
    w.material("Glass", (0.95, 0.98, 0.96), roughness=0.05, transmission=0.9, ior=1.5)
    w.material("Soap", (0.7, 0.12, 0.1))
    w.material("Column", (0.25, 0.35, 0.6))
    w.material("Walls", (0.78, 0.76, 0.7))
    w.material("Accent", (0.45, 0.6, 0.5))
    w.material("Ceiling", (0.8, 0.8, 0.8))
    w.material("CeilingLight", (0.0, 0.0, 0.0), emissive=(1.0, 0.96, 0.9), strength=16.0)

    # The tiled floor (x < XM; hexagons about 6 cm across) and the mirror floor (x > XM).
    tile_repeat = (XM - X0) / 0.125, (Z1 - Z0) / (0.125 * HEX_H / HEX_W)
    w.mesh("TileFloor", Geometry().quad_uv((X0, Y0, Z1), (XM - X0, 0, 0), (0, 0, Z0 - Z1), tile_repeat), "Tiles")
    w.mesh("MirrorFloor", Geometry().quad((XM, Y0, Z1), (X1 - XM, 0, 0), (0, 0, Z0 - Z1)), "Mirror")
    w.mesh("Ceiling", Geometry().quad((X0, Y1, Z0), (X1 - X0, 0, 0), (0, 0, Z1 - Z0)), "Ceiling")
    walls = Geometry()
    walls.quad((X0, Y0, Z0), (X1 - X0, 0, 0), (0, Y1, 0))  # -Z wall, facing +Z
    walls.quad((X1, Y0, Z1), (X0 - X1, 0, 0), (0, Y1, 0))  # +Z wall, facing -Z
    walls.quad((X0, Y0, Z1), (0, 0, Z0 - Z1), (0, Y1, 0))  # -X wall, facing +X
    w.mesh("Walls", walls, "Walls")
    w.mesh("AccentWall", Geometry().quad((X1, Y0, Z0), (0, 0, Z1 - Z0), (0, Y1, 0)), "Accent")  # +X, facing -X
    w.mesh("CeilingLight", Geometry().quad((-0.5, Y1 - 0.02, 0.5), (0, 0, -1.0), (1.0, 0, 0)), "CeilingLight")  # facing -Y

    # The vanity: a 1.2 × 0.85 × 0.55 m wooden cabinet against the -Z wall (grain along x).
    vanity = Geometry()
    vx0, vx1, vy1, vz1 = -1.7, -0.5, 0.85, Z0 + 0.55
    vanity.quad_uv((vx0, vy1, vz1), (vx1 - vx0, 0, 0), (0, 0, Z0 - vz1), (2.0, 1.0))  # top
    vanity.quad_uv((vx0, 0.0, vz1), (vx1 - vx0, 0, 0), (0, vy1, 0), (2.0, 1.5))  # front
    vanity.quad_uv((vx1, 0.0, vz1), (0, 0, Z0 - vz1), (0, vy1, 0), (1.0, 1.5))  # +x side
    vanity.quad_uv((vx0, 0.0, Z0), (0, 0, vz1 - Z0), (0, vy1, 0), (1.0, 1.5))  # -x side
    w.mesh("Vanity", vanity, "Vanity")

    # The glass jar (a 0.2 × 0.28 × 0.2 m box of thin panes, open below) and the soap bar in it.
    gx, gz = -1.0, Z0 + 0.3
    w.mesh("Jar", Geometry().box((gx - 0.1, vy1, gz - 0.1), (gx + 0.1, vy1 + 0.28, gz + 0.1), "+x-x+y+z-z"), "Glass")
    w.mesh("Soap", Geometry().box((gx - 0.05, vy1, gz - 0.035), (gx + 0.05, vy1 + 0.06, gz + 0.035), "+x-x+y+z-z"), "Soap")

    # The column standing on the mirror floor: 0.14 m across, 0.5 m tall.
    w.mesh("Column", column(Geometry(), 1.2, -0.6, 0.07, 0.5), "Column")
    return w.to_bytes()


if __name__ == "__main__":
    generator_main(__doc__, os.path.join(SCENE_DIR, "stand-in.glb"), build)

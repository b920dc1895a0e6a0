#!/usr/bin/env python3
"""Generates scenes/textured-room/textured-room.glb: a room as glTF authors write one.

A 4 × 2.6 × 4 m room (x, z in [-2, 2], y in [0, 2.6], inward faces) lit by an emissive window
(an emissive texture with dark glazing bars) in the -X wall, with a checker-textured floor, a
painting (base colour texture) on the -Z wall, an alpha-cut-out plant (three crossed leaf cards,
alphaMode MASK, double-sided) in a pot, a slab mirror (a 3 cm metal box) on the +X wall, a
double-sided curtain (one wavy sheet) beside the window, and a glTF camera node `view`.
Every texture is generated here (PNG, in the binary chunk). Deterministic: the same bytes on
every run.
"""

import math
import os

from glbtools import CLAMP, generator_main, Geometry, GlbWriter, png_bytes

SCENE_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "textured-room")

X0, X1, Y0, Y1, Z0, Z1 = -2.0, 2.0, 0.0, 2.6, -2.0, 2.0


def checker(x, y):
    """64 × 64: 8 × 8 cells of warm wood-like and cream tones."""
    if (x // 8 + y // 8) % 2 == 0:
        return (150, 96, 58, 255)
    return (226, 214, 188, 255)


def painting(x, y):
    """128 × 96: a sunset — sky gradient, a sun disc, dark hills."""
    t = y / 95.0
    sky = (int(250 - 90 * t), int(170 - 110 * t), int(90 + 60 * t))
    if (x - 84) ** 2 + (y - 40) ** 2 < 14 ** 2:
        sky = (255, 224, 120)
    hill = 70 + 12 * math.sin(x / 11.0) + 6 * math.sin(x / 4.3)
    if y > hill:
        sky = (40, 70, 45)
    return sky + (255,)


def leaf(x, y):
    """64 × 64: a leaf (alpha 255 inside an ellipse-like outline, 0 outside) with a midrib."""
    u = (x + 0.5) / 64.0 * 2 - 1
    v = (y + 0.5) / 64.0
    half_width = 0.9 * math.sin(math.pi * v) ** 0.8
    inside = abs(u) < half_width
    green = (52, 128, 46) if abs(u) > 0.06 else (120, 170, 80)
    return green + ((255 if inside else 0),)


def window(x, y):
    """32 × 32: bright glazing behind a dark cross of bars (emissive)."""
    bar = abs(x - 15.5) < 1.5 or abs(y - 15.5) < 1.5 or x < 2 or x > 29 or y < 2 or y > 29
    return (40, 38, 34, 255) if bar else (255, 250, 238, 255)


def build():
    w = GlbWriter("glint scenes/tools/make_textured_room.py")
    floor_tex = w.texture_png(png_bytes(64, 64, checker))
    painting_tex = w.texture_png(png_bytes(128, 96, painting), wrap=CLAMP)
    leaf_tex = w.texture_png(png_bytes(64, 64, leaf), wrap=CLAMP)
    window_tex = w.texture_png(png_bytes(32, 32, window), wrap=CLAMP, nearest=True)

    w.material("Floor", (0.9, 0.9, 0.9), base_texture=floor_tex)
    w.material("Walls", (0.72, 0.7, 0.66))
    w.material("Ceiling", (0.8, 0.8, 0.8))
    w.material("Painting", (0.95, 0.95, 0.95), base_texture=painting_tex)
    w.material("Frame", (0.25, 0.16, 0.08))
    w.material("Window", (0.0, 0.0, 0.0), emissive=(1.0, 0.96, 0.88), strength=12.0, emissive_texture=window_tex)
    w.material("Leaves", (0.9, 0.9, 0.9), base_texture=leaf_tex, alpha_cutoff=0.5, double_sided=True)
    w.material("Pot", (0.62, 0.32, 0.2))
    w.material("Mirror", (0.95, 0.95, 0.95), metallic=1.0, roughness=0.0)
    w.material("Curtain", (0.62, 0.12, 0.14), double_sided=True)

    # The room: floor (UVs 4× repeat: 32 checker cells across 4 m), ceiling, four walls.
    w.mesh("Floor", Geometry().quad_uv((X0, Y0, Z1), (X1 - X0, 0, 0), (0, 0, Z0 - Z1), (4.0, 4.0)), "Floor")
    w.mesh("Ceiling", Geometry().quad((X0, Y1, Z0), (X1 - X0, 0, 0), (0, 0, Z1 - Z0)), "Ceiling")
    walls = Geometry()
    walls.quad((X0, Y0, Z0), (X1 - X0, 0, 0), (0, Y1, 0))  # -Z wall, facing +Z
    walls.quad((X1, Y0, Z1), (X0 - X1, 0, 0), (0, Y1, 0))  # +Z wall, facing -Z
    walls.quad((X1, Y0, Z0), (0, 0, Z1 - Z0), (0, Y1, 0))  # +X wall, facing -X
    walls.quad((X0, Y0, Z1), (0, 0, Z0 - Z1), (0, Y1, 0))  # -X wall, facing +X
    w.mesh("Walls", walls, "Walls")

    # The window: 1.2 m wide, 1.1 m tall, 1 cm in front of the -X wall, facing +X.
    w.mesh("Window", Geometry().quad_uv((X0 + 0.01, 1.0, 0.6), (0, 0, -1.2), (0, 1.1, 0)), "Window")

    # The painting: 1.0 × 0.75 m on the -Z wall in a 4 cm frame.
    w.mesh("Painting", Geometry().quad_uv((-0.5, 1.1, Z0 + 0.02), (1.0, 0, 0), (0, 0.75, 0)), "Painting")
    w.mesh("Frame", Geometry().box((-0.54, 1.06, Z0), (0.54, 1.89, Z0 + 0.015)), "Frame")

    # The plant: a pot and three crossed leaf cards (0.7 m tall) above it.
    px, pz = 1.3, -1.3
    w.mesh("Pot", Geometry().box((px - 0.16, 0.0, pz - 0.16), (px + 0.16, 0.34, pz + 0.16), "+x-x+y+z-z"), "Pot")
    leaves = Geometry()
    for k in range(3):
        a = math.pi * k / 3.0
        d = (0.25 * math.cos(a), 0.0, 0.25 * math.sin(a))
        leaves.quad_uv((px - d[0], 0.3, pz - d[2]), (2 * d[0], 0.0, 2 * d[2]), (0.0, 0.7, 0.0))
    w.mesh("Plant", leaves, "Leaves")

    # The slab mirror: 0.9 × 1.4 m, 3 cm thick, hung 1 cm off the +X wall (front faces -X).
    w.mesh("Mirror", Geometry().box((X1 - 0.04, 0.6, -0.45), (X1 - 0.01, 2.0, 0.45)), "Mirror")

    # The curtain: one sheet beside the window, 2.3 m tall, waving in x (double-sided).
    curtain = Geometry()
    n = 12
    for i in range(n):
        z0, z1 = 0.75 + 0.06 * i, 0.75 + 0.06 * (i + 1)
        x0 = X0 + 0.12 + 0.04 * math.sin(i * math.pi / 2)
        x1 = X0 + 0.12 + 0.04 * math.sin((i + 1) * math.pi / 2)
        curtain.quad((x0, 0.15, z0), (x1 - x0, 0.0, z1 - z0), (0.0, 2.3, 0.0))
    w.mesh("Curtain", curtain, "Curtain")

    w.camera("view", (-1.2, 1.55, 1.7), (1.0, 1.0, -1.0), 60.0, aspect=1.5)
    return w.to_bytes()


if __name__ == "__main__":
    generator_main(__doc__, os.path.join(SCENE_DIR, "textured-room.glb"), build)

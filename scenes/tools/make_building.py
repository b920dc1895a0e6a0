#!/usr/bin/env python3
"""Generates a building-scale scene from the shipped rooms' contents: storeys of bays, each bay a
row of five rooms copied (with offsets and a 0°/180° turn) from the shipped scenes:

- a dining room: the breakfast room (walls, window, blinds, table, tableware, pendant lamps)
  with one of its six chairs (the seed picks which), its window and two pendant lights;
- a glossy room (glossy-room: glossy floor, mirror panel, glossy table top, copper teapot);
- two bunny rooms (bunny-mirror: mirror floor, the bunny as an impostor);
- a Cornell box.

At full size (`--size 1`) the building has 16 bays on 4 storeys: about 2.0M triangles, 96 glossy
planar reflectors (6 a bay), 48 curved reflectors, 32 impostors, window and lamp lights in every
room, and one camera path (`walkthrough`) through the ground floor's rooms. `--size 1/4` has 4
bays on 2 storeys, `--size 1/16` one bay. Every room's geometry is written out (positions and
normals per copy; a source primitive's index list is written once and shared by its copies'
accessors), so the .glb grows with the building as a real one would.

Pure Python 3 standard library; deterministic (the same arguments give the same bytes).
Units: metres, +Y up, right-handed (glTF). Storeys are 3.4 m apart; bays run along +X.

Usage: python3 scenes/tools/make_building.py OUT_DIR [--size 1/16|1/4|1] [--seed N]
writes OUT_DIR/scene.json and OUT_DIR/building.glb (never into scenes/ unless asked), and prints
the counts as one JSON line.
"""

import argparse
import copy
import json
import math
import os
import random
import struct
import sys
from array import array
from fractions import Fraction

sys.dont_write_bytecode = True  # keep scenes/tools free of __pycache__
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from glbtools import ARRAY_BUFFER, CHUNK_BIN, CHUNK_JSON, ELEMENT_ARRAY_BUFFER, FLOAT, GLB_MAGIC, UINT32, f32, read_glb, write_atomically  # noqa: E402

SCENES = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

BAYS_FULL = 16
STOREY_HEIGHT = 3.4
GAP = 0.4  # between rooms along a storey (m)
WINDOW = [8.0, 8.0, 9.0]  # radiance of the added windows, as the breakfast room's
EYE_FRACTION = 0.55  # camera height as a fraction of the room's height


class Source:
    """One shipped scene's .glb: meshes (name → primitives), materials and scene.json."""

    def __init__(self, folder, glb, scale=1.0):
        doc, blob = read_glb(os.path.join(SCENES, folder, glb))
        with open(os.path.join(SCENES, folder, "scene.json"), "rb") as f:
            self.desc = json.loads(f.read())
        for node in doc["nodes"]:
            if "mesh" in node and any(k in node for k in ("translation", "rotation", "scale", "matrix", "children")):
                raise ValueError("%s/%s: node %s has a transform; only untransformed meshes are copied" % (folder, glb, node.get("name")))
        self.scale = scale
        self.materials = doc["materials"]
        self.meshes = {}
        for mesh in doc["meshes"]:
            prims = []
            for p in mesh["primitives"]:
                if p.get("mode", 4) != 4:
                    raise ValueError("%s/%s: mesh %s: only triangle lists are copied" % (folder, glb, mesh["name"]))
                positions = self._floats(doc, blob, p["attributes"]["POSITION"], 3)
                normals = self._floats(doc, blob, p["attributes"]["NORMAL"], 3)
                indices = self._indices(doc, blob, p["indices"])
                prims.append((positions, normals, indices, self.materials[p["material"]]["name"]))
            self.meshes[mesh["name"]] = prims

    @staticmethod
    def _floats(doc, blob, index, width):
        acc = doc["accessors"][index]
        view = doc["bufferViews"][acc["bufferView"]]
        assert acc["componentType"] == FLOAT and view.get("byteStride", 4 * width) == 4 * width
        start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
        out = array("f")
        out.frombytes(blob[start : start + 4 * width * acc["count"]])
        if sys.byteorder != "little":
            out.byteswap()
        return out

    @staticmethod
    def _indices(doc, blob, index):
        acc = doc["accessors"][index]
        view = doc["bufferViews"][acc["bufferView"]]
        fmt = {5121: "B", 5123: "H", 5125: "I"}[acc["componentType"]]
        start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
        return array("I", struct.unpack_from("<%d%s" % (acc["count"], fmt), blob, start))

    def bounds(self, names):
        """(min, max) of the named meshes' positions, scaled."""
        lo, hi = [math.inf] * 3, [-math.inf] * 3
        for name in names:
            for positions, _n, _i, _m in self.meshes[name]:
                for k in range(3):
                    c = positions[k::3]
                    lo[k] = min(lo[k], min(c) * self.scale)
                    hi[k] = max(hi[k], max(c) * self.scale)
        return lo, hi


class Room:
    """A room template: which meshes of a source it copies, with their local frame (the floor
    at y = 0, the footprint centred on x = z = 0), lights, reflectors and impostors."""

    def __init__(self, kind, source, prefix, meshes, lights, reflectors, impostors):
        self.kind = kind
        self.source = source
        self.prefix = prefix
        self.meshes = meshes
        lo, hi = source.bounds(meshes)
        # Local frame: source coordinates × scale, shifted so the box sits on y = 0, centred.
        self.shift = (-(lo[0] + hi[0]) / 2, -lo[1], -(lo[2] + hi[2]) / 2)
        self.size = (hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2])
        self.lights = lights  # (name, corner, edge_u, edge_v, radiance) in scaled source coordinates
        self.reflectors = reflectors  # (mesh, kind)
        self.impostors = impostors  # mesh names


def chairs(src):
    """The breakfast room's six chairs: for each chrome base, the nearest seat and rubber foot
    set (by the centre of their bounds on the floor plan)."""

    def centre(name):
        lo, hi = src.bounds([name])
        return ((lo[0] + hi[0]) / 2, (lo[2] + hi[2]) / 2)

    def meshes_of(material, triangles=None):
        return sorted(
            n for n, prims in src.meshes.items()
            if prims[0][3] == material and (triangles is None or len(prims[0][2]) // 3 == triangles)
        )

    bases = meshes_of("Chrome")
    seats = meshes_of("WhitePlastic", 13248)
    feet = meshes_of("BlackRubber")
    assert len(bases) == len(seats) == len(feet) == 6, (bases, seats, feet)

    def nearest(name, pool):
        c = centre(name)
        return min(pool, key=lambda n: ((centre(n)[0] - c[0]) ** 2 + (centre(n)[1] - c[1]) ** 2, n))

    return [(b, nearest(b, seats), nearest(b, feet)) for b in bases]


def templates():
    """The five room kinds of a bay, in their default order."""
    breakfast = Source("breakfast-room", "breakfast_room.glb", 0.3)
    glossy = Source("glossy-room", "glossy-room.glb")
    bunny = Source("bunny-mirror", "bunny-mirror.glb")
    cornell = Source("cornell-box", "cornell_box.glb")

    chair_sets = chairs(breakfast)
    in_chairs = {m for c in chair_sets for m in c}
    dining_meshes = sorted(n for n in breakfast.meshes if n not in in_chairs)
    lights = [(l["name"], l["corner"], l["edge_u"], l["edge_v"], l["radiance"]) for l in breakfast.desc["lights"]]
    # The bounds of the room with all six chairs, so that every dining room has the same frame.
    dining = Room("Dining", breakfast, "Dining", dining_meshes, lights, [("Mesh006", "planar")], [])
    dining.chairs = chair_sets
    dining.curved = ["Mesh003", "Mesh008"]  # centrepiece pot and teapot, as in breakfast-room
    # Windows 1 cm inside the west wall, facing +X (edge_u × edge_v).
    gl = Room(
        "Glossy", glossy, "Glossy", sorted(glossy.meshes),
        [("window", [-2.99, 0.9, 1.0], [0.0, 0.0, -2.0], [0.0, 1.2, 0.0], WINDOW)],
        [("Floor", "planar"), ("MirrorPanel", "planar"), ("TableTop", "planar")], [],
    )
    gl.curved = ["Teapot"]
    bm = Room(
        "Bunny", bunny, "Bunny", sorted(bunny.meshes),
        [("window", [-1.49, 0.8, 0.6], [0.0, 0.0, -1.2], [0.0, 1.0, 0.0], WINDOW)],
        [("MirrorFloor", "planar")], ["Bunny"],
    )
    bm.curved = []
    cb = Room("Cornell", cornell, "Cornell", sorted(cornell.meshes), [], [], [])
    cb.curved = []
    return [dining, gl, bm, bm, cb]


def place(room, turn, origin):
    """A function mapping a scaled source point to the building (turn: 0 or 180 degrees about
    +Y round the room's centre; origin: where the room's floor centre goes), and one for
    directions."""
    s = -1.0 if turn else 1.0
    sx, sy, sz = room.shift

    def point(p):
        return (s * (p[0] + sx) + origin[0], p[1] + sy + origin[1], s * (p[2] + sz) + origin[2])

    def direction(d):
        return (s * d[0], d[1], s * d[2])

    return point, direction


class Writer:
    """The building's .glb: materials copied from the sources (renamed `Prefix_Name`), one mesh
    and node per copied mesh, index lists shared by the copies of a source primitive."""

    def __init__(self):
        self.doc = {
            "asset": {"version": "2.0", "generator": "glint scenes/tools/make_building.py"},
            "scene": 0,
            "scenes": [{"name": "building", "nodes": []}],
            "nodes": [],
            "meshes": [],
            "materials": [],
            "accessors": [],
            "bufferViews": [],
            "buffers": [],
        }
        self.chunks = []
        self.length = 0
        self.material_ids = {}
        self.shared_indices = {}
        self.triangles = 0

    def _view(self, data, target):
        pad = (4 - self.length % 4) % 4
        if pad:
            self.chunks.append(b"\0" * pad)
            self.length += pad
        self.doc["bufferViews"].append({"buffer": 0, "byteOffset": self.length, "byteLength": len(data), "target": target})
        self.chunks.append(data)
        self.length += len(data)
        return len(self.doc["bufferViews"]) - 1

    def _accessor(self, acc):
        self.doc["accessors"].append(acc)
        return len(self.doc["accessors"]) - 1

    def material(self, prefix, source_material):
        name = "%s_%s" % (prefix, source_material["name"])
        if name not in self.material_ids:
            m = copy.deepcopy(source_material)
            m["name"] = name
            self.material_ids[name] = len(self.doc["materials"])
            self.doc["materials"].append(m)
        return self.material_ids[name]

    def mesh(self, name, room, source_mesh, turn, origin):
        point_of, _dir = place(room, turn, origin)
        src = room.source
        s = src.scale
        sign = -1.0 if turn else 1.0
        ox, oy, oz = point_of((0.0, 0.0, 0.0))
        prims = []
        for k, (positions, normals, indices, material) in enumerate(src.meshes[source_mesh]):
            # p ↦ sign·(s·p) on x and z, s·p on y, plus the room's offset (see `place`).
            xs = [f32(sign * s * v + ox) for v in positions[0::3]]
            ys = [f32(s * v + oy) for v in positions[1::3]]
            zs = [f32(sign * s * v + oz) for v in positions[2::3]]
            pos = array("f", bytes(4 * len(positions)))
            pos[0::3], pos[1::3], pos[2::3] = array("f", xs), array("f", ys), array("f", zs)
            nor = array("f", normals)
            if turn:
                nor[0::3] = array("f", [-v for v in normals[0::3]])
                nor[2::3] = array("f", [-v for v in normals[2::3]])
            n = len(positions) // 3
            p_acc = self._accessor(
                {
                    "bufferView": self._view(_le(pos), ARRAY_BUFFER), "componentType": FLOAT, "count": n, "type": "VEC3",
                    "min": [min(xs), min(ys), min(zs)], "max": [max(xs), max(ys), max(zs)],
                }
            )
            n_acc = self._accessor({"bufferView": self._view(_le(nor), ARRAY_BUFFER), "componentType": FLOAT, "count": n, "type": "VEC3"})
            key = (src.prefix_key, source_mesh, k)
            if key not in self.shared_indices:
                self.shared_indices[key] = self._accessor(
                    {"bufferView": self._view(_le(indices), ELEMENT_ARRAY_BUFFER), "componentType": UINT32, "count": len(indices), "type": "SCALAR"}
                )
            material_id = self.material(room.prefix, next(m for m in src.materials if m["name"] == material))
            prims.append({"attributes": {"POSITION": p_acc, "NORMAL": n_acc}, "indices": self.shared_indices[key], "material": material_id, "mode": 4})
            self.triangles += len(indices) // 3
        self.doc["meshes"].append({"name": name, "primitives": prims})
        self.doc["nodes"].append({"name": name, "mesh": len(self.doc["meshes"]) - 1})
        self.doc["scenes"][0]["nodes"].append(len(self.doc["nodes"]) - 1)

    def to_bytes(self):
        pad = (4 - self.length % 4) % 4
        if pad:
            self.chunks.append(b"\0" * pad)
            self.length += pad
        self.doc["buffers"] = [{"byteLength": self.length}]
        if any("extensions" in m for m in self.doc["materials"]):
            self.doc["extensionsUsed"] = ["KHR_materials_emissive_strength"]
        text = json.dumps(self.doc, separators=(",", ":"), ensure_ascii=True, allow_nan=False).encode("ascii")
        text += b" " * ((4 - len(text) % 4) % 4)
        total = 12 + 8 + len(text) + 8 + self.length
        head = struct.pack("<III", GLB_MAGIC, 2, total) + struct.pack("<II", len(text), CHUNK_JSON) + text
        return [head, struct.pack("<II", self.length, CHUNK_BIN)] + self.chunks


def _le(a):
    """Little-endian bytes of an array."""
    if sys.byteorder != "little":
        a = array(a.typecode, a)
        a.byteswap()
    return a.tobytes()


def still(name, eye, target):
    """A 2-second camera path that stands still at `eye` looking at `target`: every frame the
    view bench times sees the same reflectors."""
    key = {"position": [round(c, 4) for c in eye], "target": [round(c, 4) for c in target], "fov_y_deg": 60.0}
    return {"name": name, "fps": 30, "keyframes": [dict(time=0.0, **key), dict(time=2.0, **key)]}


def mirror_views(ground):
    """Views for timing the reflection modes against the planar reflectors in view (the
    viewer's test: a reflector's box in the frustum, its reflecting side towards the eye; walls
    do not hide one), from the ground floor's rooms (`ground`: room, turn, origin, west to east):

    - `mirrors-1`: the westmost room, looking west at its floor from 1.3 m (with seed 1 a bunny
      room: its mirror floor alone);
    - `mirrors-3`: the first glossy room, from 1.5 m before the wall opposite its mirror panel,
      looking at the panel (its floor, panel and table top);
    - `mirrors-10`: the sixth room (the last at 1/16), 1.5 m in from its east wall, looking west
      along the storey 17 degrees down (with seed 1, ten reflectors at 1/4 and full size, all
      six at 1/16).
    """
    views = []
    room, turn, origin = ground[0]
    x0 = origin[0] - room.size[0] / 2
    views.append(still("mirrors-1", (x0 + 0.8 * room.size[0], 1.3, origin[2]), (x0, 0.2, origin[2])))
    glossy = next((g for g in ground if g[0].kind == "Glossy"), None)
    if glossy is not None:
        room, turn, origin = glossy
        point_of, dir_of = place(room, turn, origin)
        # The panel hangs on the source room's -Z wall, facing +Z.
        toward = dir_of((0.0, 0.0, -1.0))[2]
        half = room.size[2] / 2
        eye = (origin[0], 1.5, origin[2] - toward * (half - 1.5))
        views.append(still("mirrors-3", eye, (origin[0], 0.9, origin[2] + toward * half)))
    room, turn, origin = ground[min(5, len(ground) - 1)]
    x1 = origin[0] + room.size[0] / 2 - 1.5
    views.append(still("mirrors-10", (x1, 1.5, origin[2]), (x1 - 10.0, -1.5, origin[2])))
    return views


def parse_size(text):
    size = Fraction(text)
    if not 0 < size <= 1:
        raise argparse.ArgumentTypeError("--size %s: expected a fraction in (0, 1], e.g. 1/16, 1/4 or 1" % text)
    return size


def build(size, seed):
    """The .glb's chunks and the scene.json description of the building at `size`."""
    rng = random.Random(seed)
    rooms = templates()
    for r in rooms:
        r.source.prefix_key = r.prefix
    bays = max(1, round(BAYS_FULL * size))
    storeys = max(1, round(math.sqrt(bays)))
    per_storey = -(-bays // storeys)
    w = Writer()
    lights, reflectors, impostors, walk, ground = [], [], [], [], []
    for bay in range(bays):
        storey, column = divmod(bay, per_storey)
        order = list(range(len(rooms)))
        rng.shuffle(order)
        x = column * (sum(r.size[0] for r in rooms) + GAP * len(rooms))
        for slot, which in enumerate(order):
            room = rooms[which]
            turn = rng.random() < 0.5
            origin = (x + room.size[0] / 2, storey * STOREY_HEIGHT, 0.0)
            x += room.size[0] + GAP
            tag = "S%dB%dR%d_%s" % (storey, bay, slot, room.kind)
            meshes = list(room.meshes)
            if room.kind == "Dining":
                meshes += list(room.chairs[rng.randrange(len(room.chairs))])
            for m in meshes:
                w.mesh("%s_%s" % (tag, m), room, m, turn, origin)
            point_of, dir_of = place(room, turn, origin)
            for name, corner, eu, ev, radiance in room.lights:
                lights.append(
                    {
                        "name": "%s_%s" % (tag, name),
                        "corner": [round(c, 6) for c in point_of(corner)],
                        "edge_u": [round(c, 6) for c in dir_of(eu)],
                        "edge_v": [round(c, 6) for c in dir_of(ev)],
                        "radiance": radiance,
                    }
                )
            for mesh, kind in room.reflectors:
                reflectors.append({"name": "%s_%s" % (tag, mesh), "mesh": "%s_%s" % (tag, mesh), "kind": kind})
            for mesh in room.curved:
                reflectors.append({"name": "%s_%s" % (tag, mesh), "mesh": "%s_%s" % (tag, mesh), "kind": "curved"})
            for mesh in room.impostors:
                impostors.append({"mesh": "%s_%s" % (tag, mesh)})
            if storey == 0:
                walk.append((origin, room.size[1]))
                ground.append((room, turn, origin))
    keyframes = []
    for k, (origin, height) in enumerate(walk):
        eye = (origin[0], round(height * EYE_FRACTION, 3), origin[2] + 0.3)
        ahead = walk[k + 1][0] if k + 1 < len(walk) else (origin[0] + 3.0, 0.0, 0.0)
        keyframes.append(
            {
                "time": 2.0 * k,
                "position": [round(c, 4) for c in eye],
                "target": [round(ahead[0], 4), round(eye[1] - 0.3, 4), 0.0],
                "fov_y_deg": 60.0,
            }
        )
    materials = {}
    for room in rooms:
        for name, m in room.source.desc.get("materials", {}).items():
            materials["%s_%s" % (room.prefix, name)] = m
    desc = {
        "version": 1,
        "name": "building-%s-seed%d" % (str(size).replace("/", "_"), seed),
        "geometry": "building.glb",
        "materials": materials,
        "lights": lights,
        "reflectors": reflectors,
        "impostors": impostors,
        "camera_paths": [{"name": "walkthrough", "fps": 30, "keyframes": keyframes}] + mirror_views(ground),
    }
    counts = {
        "size": str(size),
        "seed": seed,
        "bays": bays,
        "storeys": storeys,
        "rooms": bays * len(rooms),
        "triangles": w.triangles,
        "planar_reflectors": sum(1 for r in reflectors if r["kind"] == "planar"),
        "curved_reflectors": sum(1 for r in reflectors if r["kind"] == "curved"),
        "impostors": len(impostors),
        "lights": len(lights),
        "emissive_materials": sum(1 for m in w.doc["materials"] if any(m.get("emissiveFactor", [0])) ),
        "keyframes": len(keyframes),
    }
    return w.to_bytes(), desc, counts


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out", help="output folder (created if missing): scene.json and building.glb")
    parser.add_argument("--size", type=parse_size, default=Fraction(1, 16), help="fraction of the full building: 1/16, 1/4 or 1 (default: %(default)s)")
    parser.add_argument("--seed", type=int, default=1, help="room order, turns and chairs (default: %(default)s)")
    args = parser.parse_args()
    chunks, desc, counts = build(args.size, args.seed)
    os.makedirs(args.out, exist_ok=True)
    write_atomically(os.path.join(args.out, "building.glb"), chunks)
    text = json.dumps(desc, indent=1, ensure_ascii=True, allow_nan=False) + "\n"
    write_atomically(os.path.join(args.out, "scene.json"), [text.encode("ascii")])
    counts["glb_bytes"] = sum(len(c) for c in chunks)
    print(json.dumps(counts, separators=(",", ":")))


if __name__ == "__main__":
    main()

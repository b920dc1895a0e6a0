"""Minimal, deterministic glTF 2.0 binary (.glb) reader and writer for the scene generators.

Pure Python 3 standard library (json, struct, math). The same inputs always give the same
bytes: no timestamps, no dict-order or float-formatting surprises (every float is rounded to
float32 before it is written, and JSON keys keep insertion order).
"""

import argparse
import json
import math
import os
import struct
import zlib

GLB_MAGIC = 0x46546C67
CHUNK_JSON = 0x4E4F534A
CHUNK_BIN = 0x004E4942

REPEAT = 10497
CLAMP = 33071

FLOAT = 5126
UINT32 = 5125
ARRAY_BUFFER = 34962
ELEMENT_ARRAY_BUFFER = 34963


def f32(x):
    """x rounded to the nearest float32 (as a Python float)."""
    return struct.unpack("<f", struct.pack("<f", x))[0]


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def normalize(a):
    n = math.sqrt(dot(a, a))
    return (a[0] / n, a[1] / n, a[2] / n)


class Geometry:
    """Positions, normals and triangle indices of one mesh, built from pieces."""

    def __init__(self):
        self.positions = []
        self.normals = []
        self.indices = []
        # TEXCOORD_0, one per vertex when used (quad_uv), else empty.
        self.uvs = []

    def quad_uv(self, corner, edge_u, edge_v, uv_scale=(1.0, 1.0), two_sided=False):
        """`quad` with TEXCOORD_0 (0, 0) at `corner` to `uv_scale` at the far corner (v runs
        along `edge_v`, downwards in the image); `two_sided` adds the same quad facing back."""
        su, sv = uv_scale
        self.quad(corner, edge_u, edge_v)
        self.uvs += [(0.0, sv), (su, sv), (su, 0.0), (0.0, 0.0)]
        if two_sided:
            self.quad(corner, edge_v, edge_u)
            self.uvs += [(0.0, sv), (0.0, 0.0), (su, 0.0), (su, sv)]
        return self

    def quad(self, corner, edge_u, edge_v):
        """The quad corner + s·edge_u + t·edge_v (2 triangles), facing edge_u × edge_v."""
        n = normalize(cross(edge_u, edge_v))
        base = len(self.positions)
        for p in (corner, add(corner, edge_u), add(add(corner, edge_u), edge_v), add(corner, edge_v)):
            self.positions.append(p)
            self.normals.append(n)
        self.indices += [base, base + 1, base + 2, base, base + 2, base + 3]
        return self

    def box(self, lo, hi, faces="+x-x+y-y+z-z"):
        """Outward faces of the axis-aligned box [lo, hi]; `faces` picks which (e.g. "+x-x+z-z")."""
        x0, y0, z0 = lo
        x1, y1, z1 = hi
        dx, dy, dz = x1 - x0, y1 - y0, z1 - z0
        table = {
            "+x": ((x1, y0, z1), (0, 0, -dz), (0, dy, 0)),
            "-x": ((x0, y0, z0), (0, 0, dz), (0, dy, 0)),
            "+y": ((x0, y1, z1), (dx, 0, 0), (0, 0, -dz)),
            "-y": ((x0, y0, z0), (dx, 0, 0), (0, 0, dz)),
            "+z": ((x0, y0, z1), (dx, 0, 0), (0, dy, 0)),
            "-z": ((x1, y0, z0), (-dx, 0, 0), (0, dy, 0)),
        }
        for key in ("+x", "-x", "+y", "-y", "+z", "-z"):
            if key in faces:
                self.quad(*table[key])
        return self

    def triangles(self):
        return len(self.indices) // 3


class GlbWriter:
    """Collects materials and meshes (one node per mesh, same name, identity transform)."""

    def __init__(self, generator, copyright=None):
        asset = {"version": "2.0", "generator": generator}
        if copyright:
            asset["copyright"] = copyright
        self.doc = {
            "asset": asset,
            "scene": 0,
            "scenes": [{"name": "scene", "nodes": []}],
            "nodes": [],
            "meshes": [],
            "materials": [],
            "accessors": [],
            "bufferViews": [],
            "buffers": [],
        }
        self.bin = bytearray()
        self.material_ids = {}
        self.uses_emissive_strength = False
        self.extensions_used = set()

    def material(
        self,
        name,
        base,
        metallic=0.0,
        roughness=1.0,
        emissive=None,
        strength=None,
        base_texture=None,
        emissive_texture=None,
        alpha_cutoff=None,
        double_sided=False,
        transmission=None,
        ior=None,
    ):
        """Adds a metallic/roughness material; `emissive` × `strength` is its radiance.
        `base_texture`/`emissive_texture`: texture indices from `texture_png`; `alpha_cutoff`:
        alphaMode MASK with that cutoff; `double_sided`: glTF doubleSided; `transmission`/`ior`:
        KHR_materials_transmission's factor and KHR_materials_ior."""
        m = {
            "name": name,
            "pbrMetallicRoughness": {
                "baseColorFactor": [f32(c) for c in base] + [1.0],
                "metallicFactor": f32(metallic),
                "roughnessFactor": f32(roughness),
            },
        }
        if base_texture is not None:
            m["pbrMetallicRoughness"]["baseColorTexture"] = {"index": base_texture}
        if emissive is not None:
            m["emissiveFactor"] = [f32(c) for c in emissive]
            if strength is not None and strength != 1.0:
                m["extensions"] = {"KHR_materials_emissive_strength": {"emissiveStrength": f32(strength)}}
                self.uses_emissive_strength = True
        if transmission is not None:
            m.setdefault("extensions", {})["KHR_materials_transmission"] = {"transmissionFactor": f32(transmission)}
            self.extensions_used.add("KHR_materials_transmission")
        if ior is not None:
            m.setdefault("extensions", {})["KHR_materials_ior"] = {"ior": f32(ior)}
            self.extensions_used.add("KHR_materials_ior")
        if emissive_texture is not None:
            m["emissiveTexture"] = {"index": emissive_texture}
        if alpha_cutoff is not None:
            m["alphaMode"] = "MASK"
            m["alphaCutoff"] = f32(alpha_cutoff)
        if double_sided:
            m["doubleSided"] = True
        self.material_ids[name] = len(self.doc["materials"])
        self.doc["materials"].append(m)
        return self.material_ids[name]

    def _view(self, data, target):
        while len(self.bin) % 4:
            self.bin.append(0)
        view = {"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data), "target": target}
        self.bin += data
        self.doc["bufferViews"].append(view)
        return len(self.doc["bufferViews"]) - 1

    def _vec3(self, values, with_bounds):
        flat = [f32(c) for v in values for c in v]
        data = struct.pack("<%df" % len(flat), *flat)
        acc = {"bufferView": self._view(data, ARRAY_BUFFER), "componentType": FLOAT, "count": len(values), "type": "VEC3"}
        if with_bounds:
            acc["min"] = [min(flat[i::3]) for i in range(3)]
            acc["max"] = [max(flat[i::3]) for i in range(3)]
        self.doc["accessors"].append(acc)
        return len(self.doc["accessors"]) - 1

    def texture_png(self, png, wrap=10497, nearest=False):
        """Adds PNG bytes as an image in the binary chunk, with a texture and its sampler
        (`wrap` for both axes); returns the texture index."""
        doc = self.doc
        for key in ("images", "textures", "samplers"):
            doc.setdefault(key, [])
        while len(self.bin) % 4:
            self.bin.append(0)
        view = {"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(png)}
        self.bin += png
        doc["bufferViews"].append(view)
        doc["images"].append({"bufferView": len(doc["bufferViews"]) - 1, "mimeType": "image/png"})
        sampler = {"wrapS": wrap, "wrapT": wrap}
        if nearest:
            sampler["magFilter"] = 9728
        doc["samplers"].append(sampler)
        doc["textures"].append({"source": len(doc["images"]) - 1, "sampler": len(doc["samplers"]) - 1})
        return len(doc["textures"]) - 1

    def camera(self, name, eye, target, yfov_deg, aspect=None):
        """Adds a perspective camera node `name` at `eye` looking at `target` (+Y up)."""
        f = normalize(sub(target, eye))
        r = normalize(cross(f, (0.0, 1.0, 0.0)))
        u = cross(r, f)
        # Rotation matrix columns: right, up, back (−forward); as a quaternion.
        m = [[r[0], u[0], -f[0]], [r[1], u[1], -f[1]], [r[2], u[2], -f[2]]]
        tr = m[0][0] + m[1][1] + m[2][2]
        if tr > 0:
            s = math.sqrt(tr + 1.0) * 2
            q = ((m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s, 0.25 * s)
        elif m[0][0] > m[1][1] and m[0][0] > m[2][2]:
            s = math.sqrt(1.0 + m[0][0] - m[1][1] - m[2][2]) * 2
            q = (0.25 * s, (m[0][1] + m[1][0]) / s, (m[0][2] + m[2][0]) / s, (m[2][1] - m[1][2]) / s)
        elif m[1][1] > m[2][2]:
            s = math.sqrt(1.0 + m[1][1] - m[0][0] - m[2][2]) * 2
            q = ((m[0][1] + m[1][0]) / s, 0.25 * s, (m[1][2] + m[2][1]) / s, (m[0][2] - m[2][0]) / s)
        else:
            s = math.sqrt(1.0 + m[2][2] - m[0][0] - m[1][1]) * 2
            q = ((m[0][2] + m[2][0]) / s, (m[1][2] + m[2][1]) / s, 0.25 * s, (m[1][0] - m[0][1]) / s)
        persp = {"yfov": f32(math.radians(yfov_deg)), "znear": 0.05}
        if aspect is not None:
            persp["aspectRatio"] = f32(aspect)
        self.doc.setdefault("cameras", []).append({"name": name, "type": "perspective", "perspective": persp})
        self.doc["nodes"].append(
            {
                "name": name,
                "camera": len(self.doc["cameras"]) - 1,
                "translation": [f32(c) for c in eye],
                "rotation": [f32(c) for c in q],
            }
        )
        self.doc["scenes"][0]["nodes"].append(len(self.doc["nodes"]) - 1)

    def mesh(self, name, geometry, material):
        """Adds `geometry` (a Geometry) as mesh `name` with node `name`, using material `material`."""
        normals = [normalize(n) for n in geometry.normals]
        pos = self._vec3(geometry.positions, True)
        nor = self._vec3(normals, False)
        uv = None
        if geometry.uvs:
            assert len(geometry.uvs) == len(geometry.positions), name
            flat = [f32(c) for t in geometry.uvs for c in t]
            data = struct.pack("<%df" % len(flat), *flat)
            self.doc["accessors"].append(
                {"bufferView": self._view(data, ARRAY_BUFFER), "componentType": FLOAT, "count": len(geometry.uvs), "type": "VEC2"}
            )
            uv = len(self.doc["accessors"]) - 1
        data = struct.pack("<%dI" % len(geometry.indices), *geometry.indices)
        self.doc["accessors"].append(
            {"bufferView": self._view(data, ELEMENT_ARRAY_BUFFER), "componentType": UINT32, "count": len(geometry.indices), "type": "SCALAR"}
        )
        idx = len(self.doc["accessors"]) - 1
        prim = {"attributes": {"POSITION": pos, "NORMAL": nor}, "indices": idx, "material": self.material_ids[material], "mode": 4}
        if uv is not None:
            prim["attributes"]["TEXCOORD_0"] = uv
        self.doc["meshes"].append({"name": name, "primitives": [prim]})
        self.doc["nodes"].append({"name": name, "mesh": len(self.doc["meshes"]) - 1})
        self.doc["scenes"][0]["nodes"].append(len(self.doc["nodes"]) - 1)

    def to_bytes(self):
        while len(self.bin) % 4:
            self.bin.append(0)
        self.doc["buffers"] = [{"byteLength": len(self.bin)}]
        used = ["KHR_materials_emissive_strength"] if self.uses_emissive_strength else []
        used += sorted(self.extensions_used)
        if used:
            self.doc["extensionsUsed"] = used
        text = json.dumps(self.doc, separators=(",", ":"), ensure_ascii=True, allow_nan=False).encode("ascii")
        text += b" " * ((4 - len(text) % 4) % 4)
        total = 12 + 8 + len(text) + 8 + len(self.bin)
        out = bytearray(struct.pack("<III", GLB_MAGIC, 2, total))
        out += struct.pack("<II", len(text), CHUNK_JSON) + text
        out += struct.pack("<II", len(self.bin), CHUNK_BIN) + self.bin
        return bytes(out)


def png_bytes(width, height, pixel):
    """An RGBA8 PNG of `pixel(x, y)` → (r, g, b, a) in 0..255, deterministic (zlib level 9)."""
    raw = bytearray()
    for y in range(height):
        raw.append(0)
        for x in range(width):
            raw += bytes(pixel(x, y))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    header = struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(bytes(raw), 9)) + chunk(b"IEND", b"")


def read_glb(path):
    """The JSON document (parsed) and the binary chunk of a .glb."""
    with open(path, "rb") as f:
        data = f.read()
    magic, _version, length = struct.unpack_from("<III", data, 0)
    if magic != GLB_MAGIC:
        raise ValueError("%s is not a .glb file" % path)
    offset, doc, blob = 12, None, None
    while offset < length:
        size, kind = struct.unpack_from("<II", data, offset)
        chunk = data[offset + 8 : offset + 8 + size]
        offset += 8 + size
        if kind == CHUNK_JSON:
            doc = json.loads(chunk)
        elif kind == CHUNK_BIN:
            blob = chunk
    return doc, blob


def read_glb_mesh(path):
    """Positions, normals and indices of the first primitive of the first mesh of a .glb."""
    doc, blob = read_glb(path)
    components = {5121: "B", 5123: "H", 5125: "I", 5126: "f"}
    widths = {"SCALAR": 1, "VEC3": 3}

    def accessor(i):
        acc = doc["accessors"][i]
        view = doc["bufferViews"][acc["bufferView"]]
        fmt = components[acc["componentType"]]
        n = widths[acc["type"]]
        size = struct.calcsize(fmt)
        stride = view.get("byteStride", size * n)
        start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
        rows = [struct.unpack_from("<%d%s" % (n, fmt), blob, start + k * stride) for k in range(acc["count"])]
        return [r[0] for r in rows] if n == 1 else [tuple(r) for r in rows]

    prim = doc["meshes"][0]["primitives"][0]
    positions = accessor(prim["attributes"]["POSITION"])
    normals = accessor(prim["attributes"]["NORMAL"])
    indices = accessor(prim["indices"])
    return positions, normals, indices


def drop_degenerate(positions, indices, rel=1e-6):
    """Indices without the triangles whose area is negligible against their longest edge²."""
    kept = []
    for t in range(0, len(indices), 3):
        a, b, c = (positions[i] for i in indices[t : t + 3])
        longest = max(dot(sub(b, a), sub(b, a)), dot(sub(c, b), sub(c, b)), dot(sub(a, c), sub(a, c)))
        n = cross(sub(b, a), sub(c, a))
        if longest > 0.0 and math.sqrt(dot(n, n)) > rel * longest:
            kept += indices[t : t + 3]
    return kept


def write_atomically(path, chunks):
    """Writes the byte strings `chunks` to `path` through a temporary file, so that a failed
    run leaves the old file whole."""
    tmp = path + ".tmp"
    with open(tmp, "wb") as f:
        for c in chunks:
            f.write(c)
    os.replace(tmp, path)


def generator_main(doc, default_out, build):
    """The command line of a scene generator: `--out` (default `default_out`) receives the
    .glb that `build()` returns; `doc`'s first paragraph is the help text."""
    parser = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    parser.add_argument("--out", default=default_out, help="output .glb (default: %(default)s)")
    args = parser.parse_args()
    data = build()
    write_atomically(args.out, [data])
    print("wrote %s (%d bytes)" % (args.out, len(data)))

"""Bakes a glint scene's lightmap with Blender's Cycles and writes D at glint's probe points.

An anchor for `cargo bench --bench radiosity -- --anchors FILE.json`: the bench scores each
Cycles run on the same probes, against the same path-traced truth, as glint's presets, and
prints both error-against-seconds curves. Not run by CI (it needs Blender).

    glint-eval probe-points scenes/cornell-box/scene.json --count 400 --seed 1 --out points.json
    blender -b --factory-startup --python benches/anchors/cycles_bake.py -- \
        --scene scenes/cornell-box/scene.json --points points.json --out cycles.json \
        --density 16,32,64 --samples 256,1024,4096 --threads 2

The scene's materials are rebuilt as glint reads them (untextured scenes only): a Lambertian
BSDF of the base colour plus, for emitters, emission of the emissive colour times its
strength from the front face only. The lightmap is D itself: a COMBINED bake of the diffuse
and emitted light (direct and indirect), no clamping, 64 bounces, in one image per material
at `--density` texels per scene unit. Each run's seconds (wall and CPU) are the UV unwrap plus
the bake, on `--threads` threads.
"""

import argparse
import array
import json
import math
import os
import sys
import time

import bmesh
import bpy
from mathutils import Vector


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else []
    p = argparse.ArgumentParser(prog="cycles_bake.py")
    p.add_argument("--scene", required=True, help="glint scene.json")
    p.add_argument("--points", required=True, help="probe points (glint-eval probe-points)")
    p.add_argument("--out", required=True, help="output JSON")
    p.add_argument(
        "--density",
        default="16,32,64",
        help="lightmap texels per scene unit on every surface, comma-separated",
    )
    p.add_argument("--samples", default="256,1024,4096", help="samples per texel, comma-separated")
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--bounces", type=int, default=64)
    return p.parse_args(argv)


def read_gltf_json(path):
    """The JSON chunk of a .glb (or a .gltf file's JSON)."""
    data = open(path, "rb").read()
    if data[:4] != b"glTF":
        return json.loads(data)
    length = int.from_bytes(data[12:16], "little")
    return json.loads(data[20 : 20 + length])


def to_blender(v):
    """glTF (Y up) to Blender (Z up), as Blender's glTF importer converts."""
    return Vector((v[0], -v[2], v[1]))


def glint_material(name, spec):
    """A Cycles material as glint reads glTF material `spec`: Lambert + front-face emission."""
    pbr = spec.get("pbrMetallicRoughness", {})
    if "baseColorTexture" in pbr or "emissiveTexture" in spec:
        sys.exit(f"material {name!r}: textured materials are not supported by this anchor")
    base = pbr.get("baseColorFactor", [1.0, 1.0, 1.0, 1.0])
    emissive = spec.get("emissiveFactor", [0.0, 0.0, 0.0])
    strength = spec.get("extensions", {}).get("KHR_materials_emissive_strength", {}).get(
        "emissiveStrength", 1.0
    )
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    nodes.clear()
    out = nodes.new("ShaderNodeOutputMaterial")
    diffuse = nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (*base[:3], 1.0)
    diffuse.inputs["Roughness"].default_value = 0.0
    shader = diffuse.outputs["BSDF"]
    if any(c > 0.0 for c in emissive):
        emission = nodes.new("ShaderNodeEmission")
        emission.inputs["Color"].default_value = (*emissive, 1.0)
        emission.inputs["Strength"].default_value = strength
        add = nodes.new("ShaderNodeAddShader")
        links.new(diffuse.outputs["BSDF"], add.inputs[0])
        links.new(emission.outputs["Emission"], add.inputs[1])
        # glTF emits from the front face only; Cycles' emission is two-sided.
        geometry = nodes.new("ShaderNodeNewGeometry")
        mix = nodes.new("ShaderNodeMixShader")
        links.new(geometry.outputs["Backfacing"], mix.inputs["Fac"])
        links.new(add.outputs["Shader"], mix.inputs[1])
        links.new(diffuse.outputs["BSDF"], mix.inputs[2])
        shader = mix.outputs["Shader"]
    links.new(shader, out.inputs["Surface"])
    return mat


def load_scene(scene_path):
    """Imports the scene's geometry as one triangulated mesh object with glint's materials."""
    desc = json.load(open(scene_path))
    folder = scene_path.rsplit("/", 1)[0] if "/" in scene_path else "."
    glb = f"{folder}/{desc['geometry']}"
    gltf = read_gltf_json(glb)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    # Blender 3.4's glTF importer still spells np.bool, which NumPy 1.24 removed.
    import numpy

    if not hasattr(numpy, "bool"):
        numpy.bool = bool
    bpy.ops.import_scene.gltf(filepath=glb)
    meshes = [o for o in bpy.context.scene.objects if o.type == "MESH"]
    bpy.ops.object.select_all(action="DESELECT")
    for o in meshes:
        o.select_set(True)
    bpy.context.view_layer.objects.active = meshes[0]
    if len(meshes) > 1:
        bpy.ops.object.join()
    obj = bpy.context.view_layer.objects.active
    bpy.ops.object.transform_apply(location=True, rotation=True, scale=True)
    specs = {m.get("name", f"material{i}"): m for i, m in enumerate(gltf.get("materials", []))}
    for slot in obj.material_slots:
        name = slot.material.name.split(".")[0] if slot.material else ""
        if name not in specs:
            sys.exit(f"{glb}: material {name!r} is not in the file's materials")
        slot.material = glint_material(name + ".glint", specs[name])
    bm = bmesh.new()
    bm.from_mesh(obj.data)
    bmesh.ops.triangulate(bm, faces=bm.faces[:])
    bm.to_mesh(obj.data)
    bm.free()
    return obj


def unwrap(obj):
    """A fresh lightmap UV layout: each material's faces unwrapped alone into the unit square
    (its own image). Returns, per material slot, its faces' area in the scene's units² and
    the share of the unit square their UVs cover."""
    mesh = obj.data
    while mesh.uv_layers:
        mesh.uv_layers.remove(mesh.uv_layers[0])
    mesh.uv_layers.new(name="lightmap")
    bpy.ops.object.mode_set(mode="EDIT")
    for k in range(len(obj.material_slots)):
        bpy.ops.mesh.select_all(action="DESELECT")
        obj.active_material_index = k
        bpy.ops.object.material_slot_select()
        bpy.ops.uv.smart_project(angle_limit=math.radians(66.0), island_margin=0.02)
    bpy.ops.object.mode_set(mode="OBJECT")
    uv = mesh.uv_layers.active.data
    areas = [[0.0, 0.0] for _ in obj.material_slots]
    for poly in mesh.polygons:
        a, b, c = (uv[i].uv for i in poly.loop_indices)
        uv_area = abs((b - a).cross(c - a)) / 2.0
        areas[poly.material_index][0] += poly.area
        areas[poly.material_index][1] += uv_area
    return areas


def sides(areas, density):
    """Each material's image side for `density` texels per scene unit on its surfaces."""
    out = []
    for area, uv_area in areas:
        side = density * math.sqrt(area / uv_area) if uv_area > 0.0 else 8.0
        out.append(min(max(int(math.ceil(side)), 8), 8192))
    return out


def bake(obj, sides, samples, seed, args):
    """Bakes D into one float image per material slot, `sides[k]` texels square; returns, per
    slot, (side, RGBA floats, rows from the bottom)."""
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.seed = seed
    scene.cycles.use_adaptive_sampling = False
    scene.cycles.use_denoising = False
    scene.cycles.max_bounces = args.bounces
    scene.cycles.diffuse_bounces = args.bounces
    scene.cycles.glossy_bounces = args.bounces
    scene.cycles.transmission_bounces = args.bounces
    scene.cycles.sample_clamp_direct = 0.0
    scene.cycles.sample_clamp_indirect = 0.0
    scene.cycles.caustics_reflective = True
    scene.cycles.caustics_refractive = True
    scene.cycles.blur_glossy = 0.0
    scene.render.threads_mode = "FIXED"
    scene.render.threads = args.threads
    if scene.world is None:
        scene.world = bpy.data.worlds.new("black")
    scene.world.use_nodes = False
    scene.world.color = (0.0, 0.0, 0.0)
    # One image per material: the bake's margin fills the gaps between islands from the
    # nearest island, which in a shared image may be another material's (the emitter's).
    images = []
    for k, slot in enumerate(obj.material_slots):
        side = sides[k]
        image = bpy.data.images.new(f"lightmap{k}", side, side, float_buffer=True, alpha=False)
        images.append(image)
        nodes = slot.material.node_tree.nodes
        node = nodes.get("lightmap") or nodes.new("ShaderNodeTexImage")
        node.name = "lightmap"
        node.image = image
        nodes.active = node
    bpy.ops.object.select_all(action="DESELECT")
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.bake(
        type="COMBINED",
        pass_filter={"EMIT", "DIRECT", "INDIRECT", "DIFFUSE"},
        margin=4,
        use_clear=True,
    )
    out = []
    for image in images:
        side = image.size[0]
        pixels = array.array("f", bytes(4 * side * side * 4))
        image.pixels.foreach_get(pixels)
        out.append((side, pixels))
    return out


def bilinear(img, uv):
    """The image at UV `uv` (texel centres at (i + 0.5) / side), clamped at the edges."""
    side, pixels = img
    x, y = uv[0] * side - 0.5, uv[1] * side - 0.5
    x0, y0 = math.floor(x), math.floor(y)
    fx, fy = x - x0, y - y0
    value = [0.0, 0.0, 0.0]
    for dy, wy in ((0, 1.0 - fy), (1, fy)):
        for dx, wx in ((0, 1.0 - fx), (1, fx)):
            xi, yi = min(max(x0 + dx, 0), side - 1), min(max(y0 + dy, 0), side - 1)
            at = 4 * (yi * side + xi)
            for c in range(3):
                value[c] += wx * wy * pixels[at + c]
    return value


def probe(obj, img, points, reach):
    """D at each probe as glint's probe finds its surface: the first front face a ray from
    position + reach·normal towards −normal meets within 2·reach."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    mesh = obj.data
    uv = mesh.uv_layers.active.data
    out = []
    for pt in points:
        p, n = to_blender(pt["position"]), to_blender(pt["normal"]).normalized()
        origin = p + n * reach
        travelled, found = 0.0, None
        start = origin
        while travelled < 2.0 * reach:
            hit, loc, normal, index, _, _ = bpy.context.scene.ray_cast(
                depsgraph, start, -n, distance=2.0 * reach - travelled
            )
            if not hit:
                break
            travelled = (loc - origin).length
            poly = mesh.polygons[index]
            if poly.normal.dot(n) > 0.0:
                found = (poly, loc)
                break
            travelled += 1e-5
            start = origin - n * travelled
        value = [0.0, 0.0, 0.0]
        if found:
            poly, loc = found
            a, b, c = (mesh.vertices[v].co for v in poly.vertices)
            # Barycentrics of loc in the triangle.
            v0, v1, v2 = b - a, c - a, loc - a
            d00, d01, d11 = v0.dot(v0), v0.dot(v1), v1.dot(v1)
            d20, d21 = v2.dot(v0), v2.dot(v1)
            den = d00 * d11 - d01 * d01
            s = (d11 * d20 - d01 * d21) / den
            t = (d00 * d21 - d01 * d20) / den
            ua, ub, uc = (uv[i].uv for i in poly.loop_indices)
            at = ua * (1.0 - s - t) + ub * s + uc * t
            value = [float(x) for x in bilinear(img[poly.material_index], at)]
        entry = {"position": pt["position"], "found": found is not None, "radiance": value}
        if "name" in pt:
            entry = {"name": pt["name"], **entry}
        out.append(entry)
    return out


def main():
    args = parse_args()
    points = json.load(open(args.points))
    desc = json.load(open(args.scene))
    obj = load_scene(args.scene)
    corners = [obj.matrix_world @ Vector(c) for c in obj.bound_box]
    lo = Vector([min(c[i] for c in corners) for i in range(3)])
    hi = Vector([max(c[i] for c in corners) for i in range(3)])
    reach = 0.01 * (hi - lo).length
    header = {
        "scene": desc["name"],
        "renderer": f"Blender {bpy.app.version_string} Cycles (CPU)",
        "threads": args.threads,
        "bounces": args.bounces,
    }
    runs = []
    for density in [float(d) for d in args.density.split(",")]:
        for samples in [int(s) for s in args.samples.split(",")]:
            start, cpu = time.perf_counter(), time.process_time()
            areas = unwrap(obj)
            per_material = sides(areas, density)
            img = bake(obj, per_material, samples, 1, args)
            seconds = time.perf_counter() - start
            cpu_seconds = time.process_time() - cpu
            texels = sum(round(uv_area * side * side) for (_, uv_area), side in zip(areas, per_material))
            values = probe(obj, img, points, reach)
            print(
                f"cycles: {density:g} texels/unit ({texels} texels), {samples} samples: "
                f"{seconds:.1f} s, {cpu_seconds:.1f} s CPU",
                flush=True,
            )
            runs.append(
                {
                    "density": density,
                    "texels": texels,
                    "samples": samples,
                    "seconds": seconds,
                    "cpu_seconds": cpu_seconds,
                    "probes": values,
                }
            )
            # After every run: a long sweep stopped midway keeps what it measured.
            write_json(args.out, {**header, "runs": runs})


def write_json(path, value):
    """`value` to `path` through a temporary file, so a stopped run leaves no torn file."""
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        json.dump(value, f, indent=1)
    os.replace(tmp, path)


main()

# Imports a derma GLB with Blender's own glTF importer (run by scripts/blender_import.sh inside
# `blender -b`) and checks what a technical artist would look for first: every named mesh, the
# face units as shape keys, and the skin material wired to its base colour, normal and
# roughness/specular maps. With RENDER=FILE.png, also renders the head with Cycles.
# Usage: blender -b --python blender_import.py -- FILE.glb [MESH ...]
import os
import sys

import numpy

# Debian's Blender 3.4 importer still uses numpy.bool, which numpy 1.24 removed.
if not hasattr(numpy, "bool"):
    numpy.bool = bool

import bpy  # noqa: E402

args = sys.argv[sys.argv.index("--") + 1:]
path, wanted = args[0], args[1:]
bpy.ops.wm.read_factory_settings(use_empty=True)
result = bpy.ops.import_scene.gltf(filepath=path)
failures = []
if result != {"FINISHED"}:
    failures.append(f"import returned {result}")

meshes = {o.name: o for o in bpy.data.objects if o.type == "MESH"}
for name in wanted:
    if name not in meshes:
        failures.append(f"no mesh named {name!r} (have {sorted(meshes)})")
for name, o in sorted(meshes.items()):
    keys = len(o.data.shape_keys.key_blocks) - 1 if o.data.shape_keys else 0
    print(f"mesh {name}: {len(o.data.vertices)} vertices, {keys} shape keys")

skin = meshes.get("skin")
if skin is not None:
    if not skin.data.shape_keys or len(skin.data.shape_keys.key_blocks) - 1 < 52:
        failures.append("the skin lacks the 52 face units as shape keys")
    mat = skin.active_material
    bsdf = next((n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED"), None)
    if bsdf is None:
        failures.append("the skin material has no Principled BSDF")
    else:
        def source(socket):
            # The image feeding a socket, through normal-map and separate nodes.
            todo = [l.from_node for l in socket.links]
            while todo:
                n = todo.pop()
                if n.type == "TEX_IMAGE":
                    return n.image.name
                todo += [l.from_node for i in n.inputs for l in i.links]
            return None

        for socket in ["Base Color", "Normal", "Roughness"]:
            img = source(bsdf.inputs[socket])
            print(f"skin {socket}: {img}")
            if img is None:
                failures.append(f"the skin's {socket} has no texture")
        # Blender 3.4's Principled BSDF has no specular-weight texture of glTF's kind: its
        # importer sets Specular from the specular colour and keeps KHR_materials_specular's
        # texture on the glTF settings group (what its exporter writes back).
        print(f"skin Specular: {bsdf.inputs['Specular'].default_value:.3f} (constant)")
        kept = [
            source(i)
            for n in mat.node_tree.nodes
            if n.type == "GROUP"
            for i in n.inputs
            if "specular" in i.name.lower() and i.is_linked
        ]
        print(f"skin KHR_materials_specular texture kept on the glTF settings: {kept}")
        if not any(kept):
            failures.append("the skin's specular texture was dropped")

out = os.environ.get("RENDER")
if out and skin is not None:
    import mathutils

    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.samples = int(os.environ.get("SAMPLES", "32"))
    scene.cycles.device = "CPU"
    scene.cycles.use_denoising = False  # Debian builds Blender without OpenImageDenoise
    scene.render.resolution_x = scene.render.resolution_y = int(os.environ.get("SIZE", "768"))
    scene.view_settings.view_transform = "Filmic"
    lo = mathutils.Vector([min(v[i] for v in skin.bound_box) for i in range(3)])
    hi = mathutils.Vector([max(v[i] for v in skin.bound_box) for i in range(3)])
    centre = skin.matrix_world @ ((lo + hi) / 2)
    height = (hi - lo).length
    cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    cam.data.lens = 85
    scene.collection.objects.link(cam)
    # glTF's +Z (the face's front) is Blender's −Y after the importer's axis conversion.
    cam.location = centre + mathutils.Vector((0, -2.1 * height, 0.05 * height))
    cam.rotation_euler = (centre - cam.location).to_track_quat("-Z", "Y").to_euler()
    scene.camera = cam
    for name, offset, power in [("key", (-1.0, -1.2, 1.0), 3.0), ("fill", (1.2, -0.8, 0.1), 0.6)]:
        light = bpy.data.objects.new(name, bpy.data.lights.new(name, "SUN"))
        light.data.energy = power
        light.data.angle = 0.2
        scene.collection.objects.link(light)
        light.rotation_euler = (-mathutils.Vector(offset)).to_track_quat("-Z", "Y").to_euler()
    scene.world = bpy.data.worlds.new("world")
    scene.world.use_nodes = True
    scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.02, 0.02, 0.025, 1)
    scene.render.filepath = out
    bpy.ops.render.render(write_still=True)
    print(f"render → {out}")

for f in failures:
    print(f"blender import: {f}", file=sys.stderr)
sys.exit(1 if failures else 0)

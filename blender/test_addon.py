"""The derma add-on in Blender, headless (bench/blender.sh): installs it from a zip, paints
derma's built-in head through its operator, checks the material's inputs are wired, the
expression sliders drive the face units, renders 256² with Cycles (no denoiser) and checks the
image is neither black nor the missing-texture pink; then paints two more objects, whose names
make the same folder name, into the same output folder and checks each object got its own
folder and no paint touched another object's textures. Run as
  blender -b --factory-startup --python-exit-code 1 --python blender/test_addon.py -- OUT_DIR
with DERMA set to the derma binary (or the derma Python package importable)."""

import hashlib
import os
import shutil
import sys

import bpy

out = os.path.abspath(sys.argv[sys.argv.index("--") + 1])
here = os.path.dirname(os.path.abspath(__file__))
os.makedirs(out, exist_ok=True)
print("derma add-on test on Blender", bpy.app.version_string)

# Install and enable the add-on as a user would: from a zip of its folder.
archive = shutil.make_archive(os.path.join(out, "derma_skin"), "zip", here, "derma_skin")
bpy.ops.preferences.addon_install(filepath=archive, overwrite=True)
bpy.ops.preferences.addon_enable(module="derma_skin")
prefs = bpy.context.preferences.addons["derma_skin"].preferences
prefs.executable = os.environ.get("DERMA", "derma")

# Empty the factory scene, then paint derma's head at 1024².
for o in list(bpy.data.objects):
    bpy.data.objects.remove(o)
scene = bpy.context.scene
s = scene.derma
s.target, s.preset, s.sex, s.age, s.size, s.seed = "BUILTIN", "tan", "female", 45.0, 1024, 3
# Every paint of this test goes into one output folder, each object's set in a folder of its own.
root = os.path.join(out, "textures")
shutil.rmtree(root, ignore_errors=True)
s.out_dir = root
assert bpy.ops.derma.paint_skin() == {"FINISHED"}

skin = next(o for o in bpy.data.objects if o.type == "MESH" and o.name.startswith("skin"))
head_dir = skin["derma_texture_dir"]
assert head_dir == os.path.join(root, "derma_head"), head_dir
mat = skin.active_material
assert mat.name.startswith("derma skin"), mat.name
nodes = mat.node_tree.nodes


def linked(node, names):
    for n in names:
        if n in node.inputs:
            return node.inputs[n].is_linked
    raise AssertionError(f"{node.name} has none of {names}")


cycles = nodes["derma skin (Cycles)"]
eevee = nodes["derma skin (Eevee)"]
for bsdf in (cycles, eevee):
    for names in (["Base Color"], ["Roughness"], ["Specular IOR Level", "Specular"], ["Normal"]):
        assert linked(bsdf, names), (bsdf.name, names)
assert linked(cycles, ["Subsurface Radius"]), "Cycles: the radius per texel"
if "Subsurface Color" in cycles.inputs:
    assert linked(cycles, ["Subsurface Color"]), "Blender 3: sss_color.png"
radius = eevee.inputs["Subsurface Radius"]
assert not radius.is_linked and all(1e-5 < r < 0.01 for r in radius.default_value), tuple(
    radius.default_value
)
assert nodes["derma normal map"].inputs["Color"].is_linked
for name in ["base_color.png", "sss_color.png"]:
    assert nodes["derma " + name].image.colorspace_settings.name == "sRGB"
for name in ["normal.png", "roughness.png", "specular.png", "sss_radius.png"]:
    assert nodes["derma " + name].image.colorspace_settings.name == "Non-Color"
print("material: every input wired; Eevee radius (m)", tuple(round(r, 5) for r in radius.default_value))

# The happiness slider poses the smile through the face units' shape keys.
keys = skin.data.shape_keys.key_blocks
fcurves = skin.data.shape_keys.animation_data.drivers
assert all(fc.driver.is_valid for fc in fcurves), [fc.data_path for fc in fcurves if not fc.driver.is_valid]
skin["happiness"] = 1.0
skin.update_tag()
scene.frame_set(scene.frame_current)
bpy.context.view_layer.update()
assert abs(keys["mouthSmileLeft"].value - 1.0) < 1e-6, keys["mouthSmileLeft"].value
assert abs(keys["cheekSquintLeft"].value - 0.7) < 1e-6, keys["cheekSquintLeft"].value
skin["happiness"] = 0.0
skin.update_tag()
scene.frame_set(scene.frame_current)
assert keys["mouthSmileLeft"].value == 0.0
print("drivers: happiness 1 → mouthSmileLeft 1, cheekSquintLeft 0.7")

# A front view, a key and a fill light; Cycles at 256², 16 samples, no denoiser.
lo = [min((skin.matrix_world @ v.co)[i] for v in skin.data.vertices) for i in range(3)]
hi = [max((skin.matrix_world @ v.co)[i] for v in skin.data.vertices) for i in range(3)]
centre = [(a + b) / 2 for a, b in zip(lo, hi)]
target = bpy.data.objects.new("target", None)
target.location = (centre[0], centre[1], centre[2] + 0.1 * (hi[2] - lo[2]))
scene.collection.objects.link(target)
cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
cam.data.lens = 85
cam.location = (centre[0], lo[1] - 0.75, target.location[2])
cam.constraints.new("TRACK_TO").target = target
scene.collection.objects.link(cam)
scene.camera = cam
for name, loc, energy in (("key", (-0.6, -1.0, 0.5), 120.0), ("fill", (0.8, -0.8, 0.1), 40.0)):
    light = bpy.data.objects.new(name, bpy.data.lights.new(name, "POINT"))
    light.data.energy = energy
    light.location = tuple(c + d for c, d in zip(centre, loc))
    scene.collection.objects.link(light)
scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = int(os.environ.get("DERMA_SAMPLES", "16"))
scene.cycles.use_denoising = False
scene.render.resolution_x = scene.render.resolution_y = int(os.environ.get("DERMA_RES", "256"))
scene.render.resolution_percentage = 100
scene.render.film_transparent = True
# derma's maps are sRGB-calibrated: show them without Filmic's tone curve.
scene.view_settings.view_transform = "Standard"
scene.render.filepath = os.path.join(out, "render.png")
bpy.ops.render.render(write_still=True)

import numpy as np  # noqa: E402  (Blender's Python; Debian: python3-numpy)

img = bpy.data.images.load(scene.render.filepath)
px = np.empty(len(img.pixels), dtype=np.float32)
img.pixels.foreach_get(px)
px = px.reshape(-1, 4)
head = px[px[:, 3] > 0.5][:, :3]
assert len(head) > 0.1 * len(px), f"the head covers {len(head)} of {len(px)} pixels"
mean = head.mean(axis=0)
pink = (head[:, 0] > 0.8) & (head[:, 1] < 0.2) & (head[:, 2] > 0.8)
assert mean.max() > 0.05, f"black: mean {mean}"
assert pink.mean() < 0.01, f"missing-texture pink on {pink.mean():.1%} of the head"
assert mean[0] > mean[1] > mean[2], f"not skin-coloured: mean RGB {mean}"
print(f"render: {scene.render.filepath}, head on {len(head)} px, mean RGB {np.round(mean, 3)}")


def digest(folder):
    """The files of a folder and a hash of each."""
    return {
        n: hashlib.sha256(open(os.path.join(folder, n), "rb").read()).hexdigest()
        for n in sorted(os.listdir(folder))
    }


head_files = digest(head_dir)
assert "base_color.png" in head_files, sorted(head_files)
# A user's own mesh: a head-sized UV sphere (0.1 m radius), active but not selected, beside
# another selected object; painted on its own UVs at 256², in metres as derma reads it.
bpy.ops.mesh.primitive_uv_sphere_add(radius=0.1, location=(1.0, 0.0, 0.0))
ball = bpy.context.active_object
bpy.ops.mesh.primitive_cube_add(size=0.2, location=(2.0, 0.0, 0.0))
cube = bpy.context.active_object
ball.data.materials.append(bpy.data.materials.new("keep me"))
ball.data.materials.append(bpy.data.materials.new("slot two"))
ball.active_material_index = 1
bpy.context.view_layer.objects.active = ball
ball.select_set(False)
# Two names that make the same safe folder name: the second object gets a folder of its own.
ball.name, cube.name = "ball: left", "ball? left"
s.target, s.size = "SELECTED", 256
assert bpy.ops.derma.paint_skin() == {"FINISHED"}
ball_dir = ball["derma_texture_dir"]
assert ball_dir == os.path.join(root, "ball__left"), ball_dir
assert [m.name for m in ball.data.materials][0] == "keep me"
assert ball.material_slots[1].material.name.startswith("derma skin")
assert cube.select_get() and not ball.select_get(), "the user's selection is given back"
import json  # noqa: E402

with open(os.path.join(ball_dir, "report.json"), encoding="utf-8") as f:
    mesh_in = json.load(f)["inputs"]["mesh"]
assert mesh_in["mm_per_unit"] == 1000.0, mesh_in
print("selected mesh: painted on its UVs in metres, in its active slot; selection kept")

# The cube, whose name makes the ball's folder name, then the ball again: three objects, three
# folders, and no paint touched another object's textures (before, every paint wrote the same
# folder and the last replaced the others' maps on disk).
ball_files = digest(ball_dir)
bpy.context.view_layer.objects.active = cube
assert bpy.ops.derma.paint_skin() == {"FINISHED"}
cube_dir = cube["derma_texture_dir"]
assert cube_dir == os.path.join(root, "ball__left-2"), cube_dir
assert "base_color.png" in digest(cube_dir)
assert cube.active_material.name.startswith("derma skin")
assert digest(head_dir) == head_files, "painting another object changed the head's textures"
assert digest(ball_dir) == ball_files, "painting the cube changed the ball's textures"
bpy.context.view_layer.objects.active = ball
s.seed = 4
assert bpy.ops.derma.paint_skin() == {"FINISHED"}
assert ball["derma_texture_dir"] == ball_dir, "a repaint keeps the object's folder"
assert digest(ball_dir) != ball_files, "the repaint wrote the ball's own folder"
assert digest(head_dir) == head_files
assert sorted(os.listdir(root)) == ["ball__left", "ball__left-2", "derma_head"], os.listdir(root)
print("folders: one per painted object (derma_head, ball__left, ball__left-2), none overwritten")
print("derma add-on test passed")

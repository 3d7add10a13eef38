# Photo sets that derma did not render (bench/photo_light.sh; docs/photo.md, "Photos under
# light derma did not make"): a real head scan with its photographed albedo, path-traced by
# Blender Cycles from five cameras under one kind of light, then given each photo's exposure,
# white balance and vignetting, and clicked at 25–40 visible vertices with 1.5 px noise.
#
#   blender -b --factory-startup --python bench/photo_light.py -- MESH.obj ALBEDO.jpg KIND OUT
#       [--width 1200] [--samples 48] [--seed 1]
#
# KIND: flat (the albedo as an emission, unlit: the pipeline's ceiling), lambert (diffuse only, a sun per view, constant ambient, no cast shadows, no bounces),
# area (an area key with soft shadows plus a fill), point (a small point key plus grey ambient:
# hard shadows), hdri (Blender's bundled courtyard.exr, CC0 by Greg Zaal / Poly Haven, turned
# per view), sky (Nishita sky with its sun; views 2–4 back-lit). Every kind but flat and lambert
# is skin: albedo, Christensen–Burley subsurface scattering and a specular lobe (Principled
# BSDF).
#
# Writes OUT/photo_K.png, OUT/points.json (derma's correspondences, at vertices' positions), OUT/truth.json
# (derma's cameras.json format: the cameras the renders used) and OUT/render.json (the light,
# exposure, white balance and vignetting of each view).

import json
import math
import os
import sys

import bpy
import numpy as np
from mathutils import Matrix, Vector
from mathutils.bvhtree import BVHTree

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from objfile import read_obj  # noqa: E402

argv = sys.argv[sys.argv.index("--") + 1:]
mesh_path, albedo_path, kind, out = argv[:4]
opts = dict(zip(argv[4::2], argv[5::2]))
width = int(opts.get("--width", 1200))
height = width * 3 // 4
samples = int(opts.get("--samples", 48))
rng = np.random.default_rng(int(opts.get("--seed", 1)))
os.makedirs(out, exist_ok=True)
VIEWS = 5


V, VT, F = read_obj(mesh_path)
# The scan's top (its scalp) must map near the top of its albedo (OBJ's v up): a copy converted
# before scripts/corpus.py flipped the model's v would wear its albedo upside down.
top = {c[1] for f in F for c in f if V[c[0], 1] > V[:, 1].max() - 0.1 * np.ptp(V[:, 1])}
if np.mean([VT[t, 1] for t in top]) < 0.5:
    sys.exit(f"{mesh_path}: its v runs downward (converted before the flip); run "
             "`python3 scripts/corpus.py fetch --only leeperrysmith` again")
mesh = bpy.data.meshes.new("scan")
mesh.from_pydata(V.tolist(), [], [[c[0] for c in f] for f in F])
uv = mesh.uv_layers.new(name="UV")
loop_uv = [VT[c[1]] for f in F for c in f]
uv.data.foreach_set("uv", np.array(loop_uv, dtype=np.float32).ravel())
mesh.polygons.foreach_set("use_smooth", [True] * len(F))
mesh.update()
scan = bpy.data.objects.new("scan", mesh)

scene = bpy.context.scene
for o in list(scene.objects):
    bpy.data.objects.remove(o)
scene.collection.objects.link(scan)

# The material: the photographed albedo, as skin (or as a Lambert surface).
mat = bpy.data.materials.new("skin")
mat.use_nodes = True
nodes, links = mat.node_tree.nodes, mat.node_tree.links
bsdf = nodes["Principled BSDF"]
tex = nodes.new("ShaderNodeTexImage")
tex.image = bpy.data.images.load(os.path.abspath(albedo_path))
tex.interpolation = "Cubic"
links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
if kind == "flat":
    # The albedo itself, unlit (an emission): what the cameras, resampling and scoring alone
    # cost, the ceiling of every other kind.
    emit = nodes.new("ShaderNodeEmission")
    links.new(tex.outputs["Color"], emit.inputs["Color"])
    links.new(emit.outputs[0], nodes["Material Output"].inputs["Surface"])
elif kind == "lambert":
    diffuse = nodes.new("ShaderNodeBsdfDiffuse")
    links.new(tex.outputs["Color"], diffuse.inputs["Color"])
    links.new(diffuse.outputs[0], nodes["Material Output"].inputs["Surface"])
else:
    # Skin: mean free paths about 1.2 / 0.5 / 0.25 mm in red / green / blue (Jensen et al.
    # 2001's skin1 σ's, rounded); the scan's unit is about 50 mm.
    links.new(tex.outputs["Color"], bsdf.inputs["Subsurface Color"])
    bsdf.subsurface_method = "BURLEY"  # Christensen-Burley: far less noise than a random walk
    bsdf.inputs["Subsurface"].default_value = 1.0 / 50.0
    bsdf.inputs["Subsurface Radius"].default_value = (1.2, 0.5, 0.25)
    bsdf.inputs["Specular"].default_value = 0.5  # F0 = 4 %: skin's index ≈ 1.4 (Weyrich 2006)
    bsdf.inputs["Roughness"].default_value = 0.4  # skin's sheen, GGX 0.3–0.45 (Weyrich 2006)
mesh.materials.append(mat)

# Cameras: five views around the face, a portrait lens, the face about half the frame.
lo, hi = V.min(0), V.max(0)
nose = V[np.argmax(V[:, 2])]
face_width = 0.35 * (hi[0] - lo[0])  # the face: about a third of a head-and-shoulders scan
target = nose + np.array([-nose[0], 0.0, -0.5 * face_width])
distance = 10.0 * face_width
focal = 0.45 * width * distance / face_width
azimuths = [-55.0, -28.0, 0.0, 27.0, 52.0]
elevations = [6.0, -4.0, 3.0, -6.0, 5.0]


def look_at(centre, at):
    f = at - centre
    f /= np.linalg.norm(f)
    r = np.cross(f, [0.0, 1.0, 0.0])
    r /= np.linalg.norm(r)
    d = np.cross(f, r)
    return np.array([r, d, f])  # rows: world → camera (x right, y down, z forward)


def rodrigues_of(R):
    angle = math.acos(max(-1.0, min(1.0, (np.trace(R) - 1) / 2)))
    if angle < 1e-12:
        return [0.0, 0.0, 0.0]
    axis = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]]) / (2 * math.sin(angle))
    return (axis * angle).tolist()


cams = []
for k in range(VIEWS):
    a, e = math.radians(azimuths[k]), math.radians(elevations[k])
    centre = target + distance * np.array([math.sin(a) * math.cos(e), math.sin(e), math.cos(a) * math.cos(e)])
    R = look_at(centre, target)
    cams.append((centre, R))

cam_data = bpy.data.cameras.new("cam")
cam_data.sensor_fit = "HORIZONTAL"
cam_data.sensor_width = 36.0
cam_data.lens = focal * 36.0 / width
cam_data.clip_start = 0.01 * distance
cam_data.clip_end = 10 * distance
cam = bpy.data.objects.new("cam", cam_data)
scene.collection.objects.link(cam)
scene.camera = cam

scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = samples
scene.cycles.use_denoising = True
try:
    scene.cycles.denoiser = "OPENIMAGEDENOISE"
except TypeError:
    scene.cycles.use_denoising = False
scene.cycles.seed = int(opts.get("--seed", 1))
scene.render.resolution_x, scene.render.resolution_y = width, height
scene.render.resolution_percentage = 100
scene.render.image_settings.file_format = "OPEN_EXR"
scene.render.image_settings.color_depth = "32"
scene.view_settings.view_transform = "Standard"
scene.render.film_transparent = False
scene.cycles.sample_clamp_indirect = 4.0  # fireflies of indirect light clamped
if kind == "lambert":
    scene.cycles.max_bounces = 0
    scene.cycles.diffuse_bounces = 0

world = bpy.data.worlds.new("world")
scene.world = world
world.use_nodes = True
bg = world.node_tree.nodes["Background"]
wlinks = world.node_tree.links


def direction(az, el):
    a, e = math.radians(az), math.radians(el)
    return np.array([math.sin(a) * math.cos(e), math.sin(e), math.cos(a) * math.cos(e)])


def aim(obj, d, dist):
    """Places obj at target + dist·d pointing at the target (-z toward it)."""
    obj.location = Vector((target + dist * d).tolist())
    obj.rotation_euler = Vector((-d).tolist()).to_track_quat("-Z", "Y").to_euler()


lights = []


def light(name, type_, energy, size=0.0):
    data = bpy.data.lights.new(name, type_)
    data.energy = energy
    if type_ == "AREA":
        data.size = size
    elif type_ in ("POINT", "SPOT"):
        data.shadow_soft_size = size
    elif type_ == "SUN":
        data.angle = math.radians(size)
    obj = bpy.data.objects.new(name, data)
    scene.collection.objects.link(obj)
    lights.append(obj)
    return obj


# Blender's environments are +Z up, the scan +Y up: turn the lookup direction +90° about X,
# then about the up axis per view.
mapping = world.node_tree.nodes.new("ShaderNodeMapping")
coord = world.node_tree.nodes.new("ShaderNodeTexCoord")
wlinks.new(coord.outputs["Generated"], mapping.inputs["Vector"])
mapping.inputs["Rotation"].default_value = (math.pi / 2, 0.0, 0.0)
if kind == "hdri":
    env = world.node_tree.nodes.new("ShaderNodeTexEnvironment")
    env.image = bpy.data.images.load(os.path.join(bpy.utils.system_resource("DATAFILES"), "studiolights", "world", "courtyard.exr"))
    wlinks.new(mapping.outputs["Vector"], env.inputs["Vector"])
    wlinks.new(env.outputs["Color"], bg.inputs["Color"])
    bg.inputs["Strength"].default_value = 1.0
elif kind == "sky":
    sky = world.node_tree.nodes.new("ShaderNodeTexSky")
    sky.sky_type = "NISHITA"
    sky.sun_disc = False  # the sun is a lamp of known direction (below)
    sky.sun_elevation = math.radians(30)
    wlinks.new(mapping.outputs["Vector"], sky.inputs["Vector"])
    wlinks.new(sky.outputs["Color"], bg.inputs["Color"])
    bg.inputs["Strength"].default_value = float(opts.get("--sky", 0.05))
else:
    grey = {"flat": 0.0, "lambert": 0.25, "area": 0.04, "point": 0.12}[kind]
    bg.inputs["Color"].default_value = (grey, grey, grey, 1.0)
    bg.inputs["Strength"].default_value = 1.0

# Per-view light: the key turns per view (a new light per photo), as when a subject turns.
keys = []
for k in range(VIEWS):
    az = azimuths[k] + rng.uniform(-45, 45)
    el = rng.uniform(10, 45)
    keys.append((az, el))
sky_azimuths = [40.0, 150.0, 180.0, 210.0, -30.0]  # views 2–4 (1-based) back-lit by the sun

scan_size = float(hi[0] - lo[0])
bvh = BVHTree.FromPolygons(V.tolist(), [[c[0] for c in f] for f in F])

# Clicks: up to 40 vertices spread over the face (farthest-point sampling in the face box),
# the visible ones per view.
face = np.where((V[:, 2] > nose[2] - 0.45 * (hi[2] - lo[2])) & (np.abs(V[:, 0]) < 0.36 * (hi[0] - lo[0]))
                & (V[:, 1] > nose[1] - 0.3 * (hi[1] - lo[1])) & (V[:, 1] < nose[1] + 0.28 * (hi[1] - lo[1])))[0]
chosen = [face[np.argmax(V[face, 2])]]
dmin = np.linalg.norm(V[face] - V[chosen[0]], axis=1)
while len(chosen) < 60:
    i = int(np.argmax(dmin))
    chosen.append(face[i])
    dmin = np.minimum(dmin, np.linalg.norm(V[face] - V[face[i]], axis=1))

normals = np.zeros_like(V)
for f in F:
    idx = [c[0] for c in f]
    n = np.cross(V[idx[1]] - V[idx[0]], V[idx[2]] - V[idx[0]])
    normals[idx] += n
normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)

render_log = []
photos, truth = [], []
for k in range(VIEWS):
    centre, R = cams[k]
    cam.matrix_world = Matrix(np.column_stack([np.column_stack([R[0], -R[1], -R[2]]), centre]).tolist() + [[0, 0, 0, 1]])
    for o in lights:
        bpy.data.objects.remove(o)
    lights.clear()
    az, el = keys[k]
    if kind == "flat":
        pass
    elif kind == "lambert":
        sun = light("key", "SUN", 4.0)
        sun.data.cycles.cast_shadow = False
        aim(sun, direction(az, el), distance)
    elif kind == "area":
        aim(light("key", "AREA", 60.0 * scan_size ** 2, 0.8 * scan_size), direction(az, el), 1.6 * scan_size)
        aim(light("fill", "AREA", 15.0 * scan_size ** 2, 1.2 * scan_size), direction(az + 180 - 2 * (az - azimuths[k]), 5), 1.8 * scan_size)
    elif kind == "point":
        aim(light("key", "POINT", 90.0 * scan_size ** 2, 0.01 * scan_size), direction(az, el), 1.6 * scan_size)
    elif kind == "hdri":
        mapping.inputs["Rotation"].default_value = (math.pi / 2, 0.0, math.radians(72 * k + rng.uniform(0, 40)))
    elif kind == "sky":
        # The sun (0.545° across); views 2–4 (1-based) have it behind the head.
        sun = light("sun", "SUN", 5.0, 0.545)
        az, el = azimuths[k] + sky_azimuths[k], rng.uniform(15, 35)
        aim(sun, direction(az, el), distance)
    scene.render.filepath = os.path.join(out, f"raw_{k}.exr")
    bpy.ops.render.render(write_still=True)
    img = bpy.data.images.load(scene.render.filepath)
    px = np.array(img.pixels[:], dtype=np.float64).reshape(height, width, 4)[::-1, :, :3]
    bpy.data.images.remove(img)
    # The camera's side: exposure to a face's midtones, white balance, vignetting, 8-bit sRGB.
    # Metered on the frame's centre (the face), as a portrait is exposed.
    centre_px = px[height // 5: 4 * height // 5, width // 4: 3 * width // 4]
    exposure = 0.85 / max(np.percentile(centre_px, 99.0), 1e-6) * rng.uniform(0.8, 1.15)
    balance = rng.uniform(0.85, 1.15, size=3)
    vign = rng.uniform(0.1, 0.35)
    ys, xs = np.mgrid[0:height, 0:width]
    r2 = ((xs + 0.5 - width / 2) ** 2 + (ys + 0.5 - height / 2) ** 2) / ((width / 2) ** 2 + (height / 2) ** 2)
    lin = np.clip(px * exposure * balance * (1 - vign * r2)[:, :, None], 0, 1)
    srgb = np.where(lin <= 0.0031308, 12.92 * lin, 1.055 * lin ** (1 / 2.4) - 0.055)
    png = bpy.data.images.new(f"photo_{k}", width, height, alpha=False)
    rgba = np.concatenate([srgb, np.ones((height, width, 1))], axis=2)[::-1]
    png.pixels.foreach_set(np.round(rgba * 255).astype(np.float32).ravel() / 255)
    png.filepath_raw = os.path.join(out, f"photo_{k}.png")
    png.file_format = "PNG"
    png.save()
    os.remove(scene.render.filepath)
    # Clicks at visible vertices facing the camera, with 1.5 px noise.
    t = -R @ centre
    pts = []
    for v in chosen:
        p = V[v]
        view = centre - p
        dist = np.linalg.norm(view)
        if np.dot(normals[v], view / dist) < 0.25:
            continue
        hit = bvh.ray_cast(Vector(centre.tolist()), Vector((-view / dist).tolist()), dist * 1.01)
        if hit[0] is None or (Vector(p.tolist()) - hit[0]).length > 1e-3 * scan_size:
            continue
        x = R @ p + t
        u = focal * x[0] / x[2] + width / 2 + rng.normal(0, 1.5)
        w = focal * x[1] / x[2] + height / 2 + rng.normal(0, 1.5)
        if 0 <= u < width and 0 <= w < height:
            pts.append({"world": [round(float(c), 6) for c in p], "pixel": [round(u, 2), round(w, 2)]})
        if len(pts) == 40:
            break
    photos.append({"image": f"photo_{k}.png", "width": width, "height": height, "points": pts})
    truth.append({"image": f"photo_{k}.png", "camera": {
        "width": width, "height": height, "rotation": rodrigues_of(R), "translation": t.tolist(),
        "focal_px": focal, "principal": [width / 2, height / 2], "k1": 0.0, "k2": 0.0},
        "rms_px": 0.0, "outliers": [], "distance_se": 0.0})
    render_log.append({"photo": k, "key_azimuth_elevation": [az, el], "exposure": exposure,
                       "white_balance": balance.tolist(), "vignetting": vign, "clicks": len(pts)})
    print(f"derma photo_light: {kind} view {k}: {len(pts)} clicks", flush=True)

json.dump({"photos": photos}, open(os.path.join(out, "points.json"), "w"), indent=1)
json.dump({"photos": truth}, open(os.path.join(out, "truth.json"), "w"), indent=1)
json.dump({"face_box": [lo[0] + 0.5 * (hi[0] - lo[0]) - 0.5 * face_width, 0.5 * (lo[0] + hi[0]) + 0.5 * face_width,
                         nose[1] - 0.45 * face_width, nose[1] + 0.55 * face_width, nose[2] - 0.5 * face_width]},
          open(os.path.join(out, "face.json"), "w"))
json.dump({"kind": kind, "samples": samples, "views": render_log,
           "scene": "bench/photo_light.py"}, open(os.path.join(out, "render.json"), "w"), indent=1)

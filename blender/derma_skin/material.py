"""The derma skin material in Blender's node tree: a texture set's maps wired into the
Principled BSDF of Blender 3.x and 4.x, one output for Cycles (subsurface radius from
sss_radius.png per texel) and one for Eevee (the radius as a constant, which Eevee needs).

The maps' meanings are derma's (docs/skin.md, docs/render.md): base_color.png sRGB diffuse
albedo; normal.png tangent space, OpenGL +Y (Blender's convention); roughness.png glTF
perceptual roughness (Blender's); specular.png = F0 / 0.08, which is Blender 3's "Specular"
(F0 = 0.08 · s: the Blender manual's Principled BSDF, "0.5 = 4 % reflectance") and Blender 4's
"Specular IOR Level" at IOR 1.5 (F0 = ((1.5 − 1)/(1.5 + 1))² · 2 · s = 0.04 · 2 · s, the same
manual's 4.x page: level 0.5 leaves the IOR's F0);
sss_color.png Burley's surface albedo (sRGB); sss_radius.png the mean free path per channel as
a fraction of 8 mm (derma_render::material::SSS_RADIUS_RANGE_MM), linear 16-bit.
"""

import os

import bpy

# sss_radius.png's full scale in mm (derma_render::material::SSS_RADIUS_RANGE_MM).
SSS_RADIUS_RANGE_MM = 8.0

# The Principled BSDF's inputs by Blender version: the first name the node has is used.
SOCKETS = {
    "base": ["Base Color"],
    "roughness": ["Roughness"],
    "specular": ["Specular IOR Level", "Specular"],
    "normal": ["Normal"],
    "sss_weight": ["Subsurface Weight", "Subsurface"],
    "sss_color": ["Subsurface Color"],
    "sss_radius": ["Subsurface Radius"],
    "sss_scale": ["Subsurface Scale"],
    "ior": ["IOR"],
}


def socket(node, key):
    """The node's input for `key` under this Blender's name for it, or None."""
    for name in SOCKETS[key]:
        if name in node.inputs:
            return node.inputs[name]
    return None


def _image(tree, set_dir, name, colour, x, y):
    path = os.path.join(set_dir, name)
    if not os.path.isfile(path):
        return None
    img = bpy.data.images.load(path, check_existing=False)
    img.colorspace_settings.name = "sRGB" if colour else "Non-Color"
    node = tree.nodes.new("ShaderNodeTexImage")
    node.image = img
    node.name = node.label = "derma " + name
    node.interpolation = "Linear"
    node.location = (x, y)
    return node


def mean_radius_mm(image):
    """Mean free path per channel (mm), the mean of sss_radius.png over the texture."""
    import numpy as np

    px = np.empty(len(image.pixels), dtype=np.float32)
    image.pixels.foreach_get(px)
    rgb = px.reshape(-1, 4)[:, :3]
    return [float(v) * SSS_RADIUS_RANGE_MM for v in rgb.mean(axis=0)]


def build(name, set_dir, mm_per_unit, uv_map=""):
    """A material named `name` from the texture set in `set_dir`, for a mesh whose one unit is
    `mm_per_unit` mm (a head imported from derma's GLB is in metres: 1000). Returns it."""
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    tree = mat.node_tree
    tree.nodes.clear()
    links = tree.links
    tex = {
        "base": _image(tree, set_dir, "base_color.png", True, -900, 400),
        "roughness": _image(tree, set_dir, "roughness.png", False, -900, 100),
        "specular": _image(tree, set_dir, "specular.png", False, -900, -150),
        "normal": _image(tree, set_dir, "normal.png", False, -900, -400),
        "sss_color": _image(tree, set_dir, "sss_color.png", True, -900, -650),
        "sss_radius": _image(tree, set_dir, "sss_radius.png", False, -900, -900),
    }
    if tex["base"] is None:
        raise RuntimeError(f"{set_dir}: no base_color.png; expected a set from `derma skin`")
    normal_map = None
    if tex["normal"] is not None:
        normal_map = tree.nodes.new("ShaderNodeNormalMap")
        normal_map.name = "derma normal map"
        normal_map.space = "TANGENT"
        normal_map.uv_map = uv_map
        normal_map.location = (-550, -400)
        links.new(tex["normal"].outputs["Color"], normal_map.inputs["Color"])
    # sss_radius.png × 8 mm is ℓ in mm; the BSDF takes scene units.
    unit_scale = SSS_RADIUS_RANGE_MM / mm_per_unit
    radius_mean = None
    if tex["sss_radius"] is not None:
        radius_mean = [r / mm_per_unit for r in mean_radius_mm(tex["sss_radius"].image)]

    for engine, y in (("CYCLES", 300), ("EEVEE", -300)):
        bsdf = tree.nodes.new("ShaderNodeBsdfPrincipled")
        bsdf.name = bsdf.label = f"derma skin ({engine.title()})"
        bsdf.location = (-200, y)
        if hasattr(bsdf, "subsurface_method"):
            bsdf.subsurface_method = "RANDOM_WALK"
        links.new(tex["base"].outputs["Color"], socket(bsdf, "base"))
        for key in ("roughness", "specular"):
            if tex[key] is not None:
                links.new(tex[key].outputs["Color"], socket(bsdf, key))
        if socket(bsdf, "ior") is not None and "Specular IOR Level" in bsdf.inputs:
            socket(bsdf, "ior").default_value = 1.5
        if normal_map is not None:
            links.new(normal_map.outputs["Normal"], socket(bsdf, "normal"))
        if radius_mean is not None:
            socket(bsdf, "sss_weight").default_value = 1.0
            if tex["sss_color"] is not None and socket(bsdf, "sss_color") is not None:
                links.new(tex["sss_color"].outputs["Color"], socket(bsdf, "sss_color"))
            scale = socket(bsdf, "sss_scale")
            radius = socket(bsdf, "sss_radius")
            if engine == "CYCLES":
                # Per texel: the map's value times its range, in scene units.
                if scale is not None:
                    scale.default_value = unit_scale
                    links.new(tex["sss_radius"].outputs["Color"], radius)
                else:
                    mul = tree.nodes.new("ShaderNodeVectorMath")
                    mul.name = "derma radius scale"
                    mul.operation = "SCALE"
                    mul.inputs["Scale"].default_value = unit_scale
                    mul.location = (-550, -900)
                    links.new(tex["sss_radius"].outputs["Color"], mul.inputs[0])
                    links.new(mul.outputs["Vector"], radius)
            else:
                # Eevee takes a constant radius: the texture's mean.
                if scale is not None:
                    scale.default_value = 1.0
                radius.default_value = radius_mean
        out = tree.nodes.new("ShaderNodeOutputMaterial")
        out.target = engine
        out.name = f"derma output ({engine.title()})"
        out.location = (200, y)
        links.new(bsdf.outputs["BSDF"], out.inputs["Surface"])
    if hasattr(mat, "use_sss_translucency"):
        mat.use_sss_translucency = True
    return mat

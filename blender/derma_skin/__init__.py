"""derma skin for Blender: a panel that paints derma's procedural biological skin (docs/skin.md)
onto the selected mesh or derma's built-in head and builds its material — base colour, normal,
roughness, specular, subsurface colour and radius for Cycles and Eevee — and, on the built-in
head, sliders for the rig library's expressions that drive its face-unit shape keys.

Install: Edit > Preferences > Add-ons > Install… (a zip of this folder), or copy the folder into
Blender's scripts/addons. derma itself is the `derma` Python package when Blender's Python can
import it, else the `derma` command line (set its path in the add-on's preferences).
"""

import os
import shutil
import tempfile

import bpy
from bpy.props import EnumProperty, FloatProperty, IntProperty, StringProperty

from . import material, runner

bl_info = {
    "name": "derma skin",
    "author": "derma",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "View3D > Sidebar > derma",
    "description": "Procedural biological skin textures and material from derma",
    "category": "Material",
}

PRESETS = [
    ("config", "Default", "derma's default person (light, ITA 48°)"),
    ("very-light", "Very light", "ITA > 55° (Chardon et al. 1991)"),
    ("light", "Light", "ITA 41–55°"),
    ("intermediate", "Intermediate", "ITA 28–41°"),
    ("tan", "Tan", "ITA 10–28°"),
    ("brown", "Brown", "ITA −30–10°"),
    ("dark", "Dark", "ITA < −30°"),
]


class DermaPreferences(bpy.types.AddonPreferences):
    bl_idname = __name__

    executable: StringProperty(
        name="derma",
        description="The derma command line (used when the derma Python package is not importable)",
        default=os.environ.get("DERMA", "derma"),
        subtype="FILE_PATH",
    )


class DermaSettings(bpy.types.PropertyGroup):
    preset: EnumProperty(name="Skin tone", items=PRESETS, default="config")
    sex: EnumProperty(
        name="Sex",
        items=[("male", "Male", "beard follicles, stubble"), ("female", "Female", "")],
        default="male",
    )
    # derma's person.age_years accepts 10–100 (derma skin --print-config).
    age: FloatProperty(name="Age", default=35.0, min=10.0, max=100.0, description="Years")
    size: IntProperty(name="Size", default=2048, min=64, max=16384, description="Texels")
    seed: IntProperty(name="Seed", default=1, min=0)
    target: EnumProperty(
        name="Paint",
        items=[
            ("BUILTIN", "derma's head", "Import derma's built-in head and paint it"),
            ("SELECTED", "Selected mesh", "Paint the active mesh on its own UVs"),
        ],
        default="BUILTIN",
    )
    out_dir: StringProperty(
        name="Textures",
        description="The folder the texture sets go in, one folder per painted object named "
        "after it (relative to the .blend file with //; an unsaved file uses a new temporary "
        "folder, which the images are then packed from)",
        default="//derma/",
        subtype="DIR_PATH",
    )


# The custom property on a painted object that records its texture folder.
DIR_KEY = "derma_texture_dir"


def texture_dir(root, name, obj=None):
    """The folder under `root` for the textures of `obj` (None: an object not yet imported)
    called `name`: its own from an earlier paint, else a new one named after it that no other
    object's textures are in (runner.texture_dir)."""
    claimed = [
        o[DIR_KEY] for o in bpy.data.objects if o != obj and isinstance(o.get(DIR_KEY), str)
    ]
    own = obj.get(DIR_KEY) if obj is not None else None
    return runner.texture_dir(root, name, own if isinstance(own, str) else None, claimed)


def _import_glb(path):
    """Imports a GLB with Blender's importer. Blender 3.4's importer still uses numpy.bool,
    which numpy 1.24 removed (Debian bookworm ships both): the alias is restored for the import."""
    import numpy as np

    shim = not hasattr(np, "bool")
    if shim:
        np.bool = np.bool_
    try:
        before = set(bpy.data.objects)
        bpy.ops.import_scene.gltf(filepath=path)
        return [o for o in bpy.data.objects if o not in before]
    finally:
        if shim:
            del np.bool


def drive_expressions(skin, objects):
    """Adds a slider per expression of derma's rig library to `skin` (0…1) and drives each face
    unit's shape key on `objects` by Σ weight · slider, capped at 1 — the library's poses
    (the node's `derma_expressions`: {expression: {unit: weight}}). Returns the units driven."""
    table = skin.get("derma_expressions")
    if not table:
        return []
    table = {e: dict(units) for e, units in table.items()}
    for e in table:
        skin[e] = 0.0
        ui = skin.id_properties_ui(e)
        ui.update(min=0.0, max=1.0, soft_min=0.0, soft_max=1.0, description=f"derma rig: {e}")
    by_unit = {}
    for e, units in table.items():
        for unit, w in units.items():
            by_unit.setdefault(unit, []).append((e, float(w)))
    driven = set()
    for obj in objects:
        keys = getattr(obj.data, "shape_keys", None)
        if keys is None:
            continue
        for unit, terms in by_unit.items():
            block = keys.key_blocks.get(unit)
            if block is None:
                continue
            fc = block.driver_add("value")
            d = fc.driver
            d.type = "SCRIPTED"
            names = []
            for i, (e, _) in enumerate(terms):
                v = d.variables.new()
                v.name = f"e{i}"
                v.type = "SINGLE_PROP"
                v.targets[0].id = skin
                v.targets[0].data_path = f'["{e}"]'
                names.append(v.name)
            total = " + ".join(f"{n} * {w:g}" for n, (_, w) in zip(names, terms))
            d.expression = f"min(1.0, {total})"
            driven.add(unit)
    return sorted(driven)


class DERMA_OT_paint_skin(bpy.types.Operator):
    """Paint derma's skin on the selected mesh or derma's head and build its material"""

    bl_idname = "derma.paint_skin"
    bl_label = "Paint skin"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        s = context.scene.derma
        prefs = context.preferences.addons[__name__].preferences
        # A path relative to an unsaved .blend has no folder: paint into a temporary one and
        # pack the images into the .blend, so the material keeps them.
        transient = not s.out_dir or (s.out_dir.startswith("//") and not bpy.data.filepath)
        root = tempfile.mkdtemp(prefix="derma-") if transient else bpy.path.abspath(s.out_dir)
        # One folder per painted object, named after it, so a paint never writes over another
        # object's textures (the builtin head's folder: derma_head, derma_head-2, …).
        try:
            if s.target == "SELECTED":
                obj = context.active_object
                if obj is None or obj.type != "MESH" or not obj.data.uv_layers:
                    self.report({"ERROR"}, "select a mesh with UVs, or paint derma's head")
                    return {"CANCELLED"}
                out = texture_dir(root, obj.name, obj)
                # The exported mesh goes beside, not into, the set's folder: derma replaces
                # that folder whole and refuses one holding files that are not the set's.
                mesh_dir = tempfile.mkdtemp(prefix="derma-mesh-")
                mesh = os.path.join(mesh_dir, "mesh.obj")
                # Export the active mesh alone, then give the user their selection back.
                selected = list(context.selected_objects)
                for o in selected:
                    o.select_set(False)
                obj.select_set(True)
                try:
                    bpy.ops.wm.obj_export(
                        filepath=mesh,
                        export_selected_objects=True,
                        export_materials=False,
                        export_normals=True,
                        export_uv=True,
                    )
                finally:
                    obj.select_set(obj in selected)
                    for o in selected:
                        o.select_set(True)
                try:
                    report = runner.run_skin(
                        prefs.executable, out, s.preset, s.sex, s.age, s.size, s.seed, mesh=mesh
                    )
                finally:
                    shutil.rmtree(mesh_dir, ignore_errors=True)
                skin, objects = obj, [obj]
            else:
                out = texture_dir(root, "derma_head")
                report = runner.run_skin(
                    prefs.executable, out, s.preset, s.sex, s.age, s.size, s.seed, glb=True
                )
                objects = _import_glb(os.path.join(out, "head.glb"))
                skin = next(o for o in objects if o.type == "MESH" and o.name.startswith("skin"))
        except Exception as e:  # derma's message names what is wrong
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        skin[DIR_KEY] = out
        uv = skin.data.uv_layers.active.name if skin.data.uv_layers else ""
        mat = material.build("derma skin", out, runner.mm_per_unit(report), uv_map=uv)
        if transient:
            for node in mat.node_tree.nodes:
                if node.type == "TEX_IMAGE" and node.image is not None:
                    node.image.pack()
        # The skin takes the material in its active slot (a new slot when it has none); other
        # slots of a user's multi-material mesh are left alone.
        if skin.material_slots:
            skin.material_slots[skin.active_material_index].material = mat
        else:
            skin.data.materials.append(mat)
        driven = drive_expressions(skin, objects) if s.target == "BUILTIN" else []
        self.report(
            {"INFO"},
            f"derma: {report.get('size')}² set in {out}; {len(driven)} face units driven",
        )
        return {"FINISHED"}


class DERMA_PT_panel(bpy.types.Panel):
    bl_label = "derma skin"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "derma"

    def draw(self, context):
        s = context.scene.derma
        col = self.layout.column()
        col.prop(s, "target")
        col.prop(s, "preset")
        col.prop(s, "sex")
        col.prop(s, "age")
        col.prop(s, "size")
        col.prop(s, "seed")
        col.prop(s, "out_dir")
        col.operator(DERMA_OT_paint_skin.bl_idname)
        obj = context.active_object
        if obj is not None and obj.get("derma_expressions"):
            box = self.layout.box()
            box.label(text="Expressions (drive the face units)")
            for e in obj["derma_expressions"].keys():
                if e in obj:
                    box.prop(obj, f'["{e}"]', text=e, slider=True)


CLASSES = (DermaPreferences, DermaSettings, DERMA_OT_paint_skin, DERMA_PT_panel)


def register():
    for c in CLASSES:
        bpy.utils.register_class(c)
    bpy.types.Scene.derma = bpy.props.PointerProperty(type=DermaSettings)


def unregister():
    del bpy.types.Scene.derma
    for c in reversed(CLASSES):
        bpy.utils.unregister_class(c)

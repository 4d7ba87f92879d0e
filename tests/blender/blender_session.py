"""Run inside real Blender by tests/blender/test_blender_addon.py (not collected by pytest):

    blender -b CACHE/fire.blend --factory-startup --python blender_session.py -- JOB.json

JOB: {"zip", "executable", "frame", "out", "upright_vdb"}. It installs and enables the add-on
from its zip, then records in OUT/session.json what the tests check: the add-on's classes, the
report of "Render with incandescent" on a mesh, the render operator's EXR and command, Blender's
own projection of test points through the camera, the baked emission object rendered by Cycles
(EXR), and how a --for blender VDB loads (grid names, bounding box, Principled Volume's
attribute names). Every step's failure is recorded, not raised, so one failure shows alone.
"""

import json
import sys
import traceback
from pathlib import Path

import bpy
from bpy_extras.object_utils import world_to_camera_view
from mathutils import Vector

JOB = json.loads(Path(sys.argv[sys.argv.index("--") + 1]).read_text())
bpy.context.scene.render.resolution_percentage = JOB.get("percent", 100)
OUT = Path(JOB["out"])
RESULT: dict = {}


def step(name):
    def wrap(function):
        try:
            RESULT[name] = function()
        except Exception as error:  # recorded for the test to show
            RESULT[name] = {
                "failed": f"{type(error).__name__}: {error}",
                "trace": traceback.format_exc(),
            }
        return function

    return wrap


@step("install")
def install():
    bpy.ops.preferences.addon_install(filepath=JOB["zip"], overwrite=True)
    bpy.ops.preferences.addon_enable(module="incandescent_blender")
    preferences = bpy.context.preferences.addons["incandescent_blender"].preferences
    preferences.executable = JOB["executable"]
    names = [
        "INCANDESCENT_OT_render",
        "INCANDESCENT_OT_render_animation",
        "INCANDESCENT_OT_bake_emission",
        "INCANDESCENT_PT_panel",
    ]
    return {
        "registered": {n: hasattr(bpy.types, n) for n in names},
        "operators": [
            hasattr(bpy.ops.incandescent, op)
            for op in ("render", "render_animation", "bake_emission")
        ],
        "module": bpy.context.preferences.addons["incandescent_blender"].module,
    }


def activate(obj):
    for other in bpy.context.view_layer.objects:
        other.select_set(other is obj)
    bpy.context.view_layer.objects.active = obj


def operator_error(call):
    """What an operator reported as an error (bpy.ops raises it as a RuntimeError), else None."""
    try:
        result = call()
    except RuntimeError as error:
        return {"error": str(error)}
    return {"result": sorted(result)}


@step("not_volume")
def not_volume():
    activate(bpy.data.objects["FireEmitter"])
    return operator_error(bpy.ops.incandescent.render)


@step("render")
def render():
    scene = bpy.context.scene
    scene.frame_set(JOB["frame"])
    domain = bpy.data.objects["FireDomain"]
    activate(domain)
    outcome = operator_error(bpy.ops.incandescent.render)
    import incandescent_blender as addon

    exr = addon.output_folder() / f"FireDomain_{JOB['frame']:04d}.exr"
    frame_matrix = addon.domain_frame_matrix(domain, addon.fluid_domain(domain))
    corners = [domain.matrix_world @ Vector(c) for c in domain.bound_box]
    centre = sum(corners, Vector()) / 8.0
    points = [centre] + [centre.lerp(c, 0.8) for c in corners]
    projected = [list(world_to_camera_view(scene, scene.camera, p)) for p in points]
    return outcome | {
        "exr": str(exr),
        "sidecar": json.loads(exr.with_suffix(".json").read_text())
        if exr.with_suffix(".json").exists()
        else None,
        "frame_matrix": [list(r) for r in frame_matrix],
        "points_world": [list(p) for p in points],
        "projected": projected,
        "images": [image.filepath for image in bpy.data.images],
    }


#: Camera variants whose conversion is checked against Blender's projection: (type, sensor fit).
VARIANTS = [
    ("ORTHO", "AUTO"),
    ("PERSP", "HORIZONTAL"),
    ("PERSP", "VERTICAL"),
    ("ORTHO", "VERTICAL"),
]


@step("variants")
def variants():
    """The add-on's camera arguments and Blender's projection of the points, per variant."""
    import incandescent_blender as addon

    scene, domain = bpy.context.scene, bpy.data.objects["FireDomain"]
    data = scene.camera.data
    saved = (data.type, data.sensor_fit, data.ortho_scale)
    frame_matrix = addon.domain_frame_matrix(domain, addon.fluid_domain(domain))
    corners = [domain.matrix_world @ Vector(c) for c in domain.bound_box]
    centre = sum(corners, Vector()) / 8.0
    points = [centre] + [centre.lerp(c, 0.8) for c in corners]
    out = []
    for kind, fit in VARIANTS:
        data.type, data.sensor_fit, data.ortho_scale = kind, fit, 2.5
        bpy.context.view_layer.update()
        out.append(
            {
                "variant": [kind, fit],
                "arguments": addon.camera_arguments(scene, frame_matrix),
                "projected": [list(world_to_camera_view(scene, scene.camera, p)) for p in points],
            }
        )
    data.type, data.sensor_fit, data.ortho_scale = saved
    return {
        "points_world": [list(p) for p in points],
        "frame_matrix": [list(r) for r in frame_matrix],
        "cases": out,
    }


@step("animation")
def animation():
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = JOB["frame"] - 1, JOB["frame"]
    activate(bpy.data.objects["FireDomain"])
    outcome = operator_error(bpy.ops.incandescent.render_animation)
    import incandescent_blender as addon

    folder = addon.output_folder()
    return outcome | {"exrs": sorted(p.name for p in folder.glob("FireDomain_*.exr"))}


def cycles_settings(scene):
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = JOB.get("samples", 16)
    scene.cycles.use_denoising = False
    scene.render.film_transparent = True
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    world = bpy.data.worlds.new("black")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    scene.world = world
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    scene.render.image_settings.color_mode = "RGBA"


@step("cycles")
def cycles():
    scene = bpy.context.scene
    domain = bpy.data.objects["FireDomain"]
    activate(domain)
    outcome = operator_error(bpy.ops.incandescent.bake_emission)
    scene.frame_set(JOB["frame"])
    baked = bpy.data.objects.get("FireDomain emission")
    if baked:
        baked.data.grids.load()
    cycles_settings(scene)
    scene.render.filepath = str(OUT / "cycles.exr")
    bpy.ops.render.render(write_still=True)
    activate(baked)
    again = operator_error(bpy.ops.incandescent.render)
    import incandescent_blender as addon

    rendered = addon.output_folder() / f"FireDomain_emission_{JOB['frame']:04d}.exr"
    material = baked.data.materials[0] if baked else None
    return outcome | {
        "exr": str(OUT / "cycles.exr"),
        "domain_hidden": domain.hide_render,
        "grids": [g.name for g in baked.data.grids] if baked else None,
        "material_nodes": [n.bl_idname for n in material.node_tree.nodes] if material else None,
        "baked_render": again | {"exr": str(rendered)},
    }


@step("eevee")
def eevee():
    """The baked emission object again, rendered by EEVEE (volumetrics at 2-pixel tiles)."""
    scene = bpy.context.scene
    scene.render.engine = "BLENDER_EEVEE"
    scene.eevee.volumetric_tile_size = "2"
    scene.eevee.volumetric_samples = 128
    scene.eevee.taa_render_samples = 16
    scene.render.filepath = str(OUT / "eevee.exr")
    bpy.ops.render.render(write_still=True)
    return {"exr": str(OUT / "eevee.exr")}


@step("upright")
def upright():
    volume = bpy.data.volumes.new("upright")
    volume.filepath = JOB["upright_vdb"]
    volume.grids.load()
    obj = bpy.data.objects.new("upright", volume)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.update()
    corners = [list(obj.matrix_world @ Vector(c)) for c in obj.bound_box]
    size = [max(c[i] for c in corners) - min(c[i] for c in corners) for i in range(3)]
    node = bpy.data.materials.new("probe")
    node.use_nodes = True
    principled = node.node_tree.nodes.new("ShaderNodeVolumePrincipled")
    return {
        "grids": {g.name: g.data_type for g in volume.grids},
        "size": size,
        "density_attribute": principled.inputs["Density Attribute"].default_value,
        "temperature_attribute": principled.inputs["Temperature Attribute"].default_value,
    }


@step("volume_bake")
def volume_bake():
    """Bake physical emission on a plain volume object (the --for blender campfire)."""
    obj = bpy.data.objects["upright"]
    activate(obj)
    outcome = operator_error(bpy.ops.incandescent.bake_emission)
    baked = bpy.data.objects.get("upright emission")
    return outcome | {"file": baked.data.filepath if baked else None}


(OUT / "session.json").write_text(json.dumps(RESULT, indent=1, default=str))

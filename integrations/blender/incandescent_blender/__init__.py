"""incandescent for Blender: render volume objects and Mantaflow fire with incandescent, and bake
its physical emission into grids a stock Principled Volume renders (docs/blender.md).

The add-on calls the installed ``incandescent`` executable (its path in the add-on's
preferences) as a subprocess; every failure is a message in Blender's report area.
"""

import json
import os
import shutil
import subprocess
from pathlib import Path

import bpy

from . import convert

bl_info = {
    "name": "incandescent",
    "author": "incandescent contributors",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "Properties › Object › incandescent",
    "description": "Physically based fire: render volumes and Mantaflow caches with incandescent, "
    "bake its emission colours for Cycles and EEVEE",
    "category": "Render",
}

PRESETS = [
    ("AUTO", "Auto", "Fluid domains: blender; volume objects: blender if they hold a flame grid"),
    ("blender", "Blender (Mantaflow)", "Temperature from the flame grid as Cycles renders it"),
    ("houdini", "Houdini Pyro", "Normalised temperature: 300 K + 1000 K per unit"),
    ("embergen", "EmberGen", "Normalised temperature: 300 K + 1000 K per unit"),
    ("NONE", "Kelvin", "The file's temperature grid is in kelvin"),
]
#: Blender's default Flame Ignition and Maximum Temperature (the blender preset's defaults).
FLAME_DEFAULTS = (1.5, 3.0)


class IncandescentError(Exception):
    """A failure to report to the user as one line (never a traceback)."""


class IncandescentPreferences(bpy.types.AddonPreferences):
    bl_idname = __name__

    executable: bpy.props.StringProperty(
        name="incandescent executable",
        description="Path of the installed incandescent command (empty: found on PATH)",
        subtype="FILE_PATH",
        default="",
    )
    backend: bpy.props.EnumProperty(
        name="Backend",
        items=[
            ("auto", "Auto", ""),
            ("cpu", "CPU", ""),
            ("cuda", "CUDA", ""),
            ("reference", "Reference", ""),
        ],
        default="auto",
    )

    def draw(self, context):
        self.layout.prop(self, "executable")
        self.layout.prop(self, "backend")


def _preferences():
    return bpy.context.preferences.addons[__name__].preferences


def executable() -> str:
    given = bpy.path.abspath(_preferences().executable) if _preferences().executable else ""
    found = given or shutil.which("incandescent") or ""
    if not found or not os.access(found, os.X_OK):
        where = f"{given!r} is not an executable file" if given else "not found on PATH"
        raise IncandescentError(
            f"incandescent executable {where}: set its path in Edit › Preferences › Add-ons › "
            "incandescent"
        )
    return found


def run(arguments) -> str:
    """Run incandescent; its one-line error becomes an IncandescentError."""
    command = [executable(), *arguments]
    try:
        done = subprocess.run(command, capture_output=True, text=True, check=False)
    except OSError as error:
        raise IncandescentError(f"cannot run {command[0]}: {error}") from None
    if done.returncode != 0:
        lines = (done.stderr + done.stdout).strip().splitlines() or [
            f"exit status {done.returncode}"
        ]
        error_lines = [line for line in lines if line.startswith("error:")]
        raise IncandescentError(f"incandescent {arguments[0]}: {(error_lines or lines)[-1]}")
    return done.stdout


# --- what to render: the object's file at a frame, and where it sits -------------------------


def fluid_domain(obj):
    """The object's Mantaflow domain settings, or None."""
    for modifier in getattr(obj, "modifiers", ()):
        if modifier.type == "FLUID" and modifier.fluid_type == "DOMAIN":
            return modifier.domain_settings
    return None


def check_volume(obj):
    """``obj`` must be a volume object or a gas fluid domain."""
    if obj is None:
        raise IncandescentError("no active object: select a volume object or a fluid domain")
    if obj.type == "VOLUME" or fluid_domain(obj) is not None:
        return
    raise IncandescentError(
        f"object {obj.name!r} is a {obj.type.lower()}, not a volume: select a volume object "
        "(a .vdb) or a fluid domain with a baked gas cache"
    )


def _domain_cache(obj, settings, frame: int) -> Path:
    if settings.domain_type != "GAS":
        raise IncandescentError(
            f"fluid domain {obj.name!r} is a liquid domain; incandescent renders gas (fire, smoke)"
        )
    if settings.cache_data_format != "OPENVDB":
        raise IncandescentError(
            f"fluid domain {obj.name!r} caches in {settings.cache_data_format}: set Cache › Format "
            "Volumes to OpenVDB and bake again"
        )
    if settings.use_adaptive_domain:
        raise IncandescentError(
            f"fluid domain {obj.name!r} is adaptive: its cache frames move; turn Adaptive Domain "
            "off and bake again"
        )
    path = Path(bpy.path.abspath(settings.cache_directory)) / "data" / f"fluid_data_{frame:04d}.vdb"
    if not path.is_file():
        raise IncandescentError(
            f"fluid domain {obj.name!r} has no cache file for frame {frame} ({path}): bake the "
            "domain first"
        )
    return path


def domain_frame_matrix(obj, settings):
    """The cache file's coordinates → Blender's world, for a fluid domain."""
    corners = [list(c) for c in obj.bound_box]
    low = [min(c[i] for c in corners) for i in range(3)]
    size = [max(c[i] for c in corners) - low[i] for i in range(3)]
    offset = convert.domain_offset(low, size, settings.resolution_max)
    world = [list(row) for row in obj.matrix_world]
    return convert.multiply(world, convert.translation(offset))


def source_of(obj, frame: int):
    """(file, file → world matrix, preset arguments) of ``obj`` at ``frame``."""
    check_volume(obj)
    settings = fluid_domain(obj)
    if settings is not None:
        path = _domain_cache(obj, settings, frame)
        options = (settings.flame_ignition, settings.flame_max_temp)
        return path, domain_frame_matrix(obj, settings), _preset_arguments("blender", options)
    volume = obj.data
    bpy.context.scene.frame_set(frame)
    volume.grids.load()
    path = Path(bpy.path.abspath(volume.grids.frame_filepath or volume.filepath))
    if not path.is_file():
        raise IncandescentError(
            f"volume {obj.name!r}: its file {path} does not exist at frame {frame}"
        )
    preset, names = obj.incandescent_preset, {grid.name for grid in volume.grids}
    if preset == "AUTO":
        preset = "blender" if "flame" in names and "color" not in names else "NONE"
    arguments = _preset_arguments(preset, FLAME_DEFAULTS)
    if preset == "NONE" and "color" in names and "density" in names:  # written --for blender
        arguments += ["--absorption-grid", "density"]
    return path, volume_frame_matrix(obj), arguments


def volume_frame_matrix(obj):
    """A volume object's file coordinates → Blender's world. incandescent reads voxel i of a
    grid centred at the grid transform's index i (OpenVDB's convention); Blender shows it over
    the cell from index i to i + 1, so the file's frame is shifted half a voxel up each axis."""
    grids = list(obj.data.grids)
    index = (
        [list(row) for row in grids[0].matrix_object] if grids else convert.translation((0, 0, 0))
    )
    half = [0.5 * sum(index[i][j] for j in range(3)) for i in range(3)]
    world = [list(row) for row in obj.matrix_world]
    return convert.multiply(world, convert.translation(half))


def _preset_arguments(preset: str, flame_options) -> list:
    if preset == "NONE":
        return ["--up-axis", "z"]
    arguments = ["--preset", preset]
    if preset == "blender" and tuple(flame_options) != FLAME_DEFAULTS:
        ignition, max_temp = flame_options
        arguments += ["--preset-options", f"ignition={ignition!r},max_temp={max_temp!r}"]
    return arguments


def camera_arguments(scene, frame_matrix):
    camera = scene.camera
    if camera is None or camera.type != "CAMERA":
        raise IncandescentError("the scene has no active camera: add one and make it active")
    render = scene.render
    if abs(render.pixel_aspect_x - render.pixel_aspect_y) > 1e-9:
        raise IncandescentError(
            "the render's pixel aspect is not 1:1; incandescent renders square pixels"
        )
    scale = render.resolution_percentage / 100.0
    width, height = (
        max(1, int(render.resolution_x * scale)),
        max(1, int(render.resolution_y * scale)),
    )
    data = camera.data
    names = ("lens", "sensor_width", "sensor_height", "sensor_fit", "type", "ortho_scale",
             "shift_x", "shift_y")  # fmt: skip
    fields = {name: getattr(data, name) for name in names}
    try:
        return convert.camera_arguments([list(r) for r in camera.matrix_world], frame_matrix,
                                        fields, width, height)  # fmt: skip
    except ValueError as error:
        raise IncandescentError(f"camera {camera.name!r}: {error}") from None


def output_folder() -> Path:
    blend = bpy.data.filepath
    base = Path(blend).parent if blend else Path(bpy.app.tempdir or "/tmp")
    return base / "incandescent"


def render_frame(obj, scene, frame: int) -> Path:
    """Render ``obj`` at ``frame`` through the scene's camera to an EXR; returns its path."""
    scene.frame_set(frame)
    source, frame_matrix, preset = source_of(obj, frame)
    camera = camera_arguments(scene, frame_matrix)
    out = output_folder() / f"{bpy.path.clean_name(obj.name)}_{frame:04d}.exr"
    out.parent.mkdir(parents=True, exist_ok=True)
    arguments = ["render", str(source), *preset, *camera, "-o", str(out), "--overwrite",
                 "--backend", _preferences().backend]  # fmt: skip
    run(arguments)
    sidecar = {"command": arguments, "source": str(source), "frame": frame}
    out.with_suffix(".json").write_text(json.dumps(sidecar, indent=1))
    return out


def show(path: Path, context):
    """Load the EXR into Blender's image editors (reloaded if already loaded)."""
    image = bpy.data.images.load(str(path), check_existing=True)
    image.reload()
    for area in getattr(context.screen, "areas", ()) if context.screen else ():
        if area.type == "IMAGE_EDITOR":
            area.spaces.active.image = image
    return image


# --- operators -------------------------------------------------------------------------------


class _Reporting:
    """execute() through ``run_operator``; an IncandescentError (or anything else) is reported as
    one line and the operator is cancelled — never a traceback."""

    def execute(self, context):
        try:
            return self.run_operator(context)
        except IncandescentError as error:
            self.report({"ERROR"}, str(error))
        except Exception as error:  # an unexpected failure: still one line in the report area
            self.report({"ERROR"}, f"incandescent: {type(error).__name__}: {error}")
        return {"CANCELLED"}


class INCANDESCENT_OT_render(_Reporting, bpy.types.Operator):
    """Render the active volume object (or fluid domain's cache frame) with incandescent"""

    bl_idname = "incandescent.render"
    bl_label = "Render with incandescent"

    def run_operator(self, context):
        path = render_frame(context.active_object, context.scene, context.scene.frame_current)
        show(path, context)
        self.report({"INFO"}, f"incandescent: rendered {path}")
        return {"FINISHED"}


class INCANDESCENT_OT_render_animation(_Reporting, bpy.types.Operator):
    """Render the scene's frame range of the active volume or fluid domain with incandescent"""

    bl_idname = "incandescent.render_animation"
    bl_label = "Render animation"

    def run_operator(self, context):
        scene, obj = context.scene, context.active_object
        check_volume(obj)
        current = scene.frame_current
        paths = []
        try:
            for frame in range(scene.frame_start, scene.frame_end + 1, scene.frame_step):
                paths.append(render_frame(obj, scene, frame))
        finally:
            scene.frame_set(current)
        show(paths[-1], context)
        self.report({"INFO"}, f"incandescent: rendered {len(paths)} frames into {paths[-1].parent}")
        return {"FINISHED"}


def bake_frames(obj, scene):
    """Convert each frame's file with ``--for blender`` (our emission baked as ``color``) into a
    folder beside it; returns the files written."""
    settings = fluid_domain(obj)
    if settings is not None:
        frames = range(settings.cache_frame_start, settings.cache_frame_end + 1)
    else:
        frames = (
            range(scene.frame_start, scene.frame_end + 1)
            if obj.data.is_sequence
            else [scene.frame_current]
        )
    written = []
    for frame in frames:
        source, _, preset = source_of(obj, frame)
        out = source.parent.parent / "incandescent" / f"emission_{frame:04d}.vdb" if settings else \
            source.parent / "incandescent" / f"emission_{source.stem}.vdb"  # fmt: skip
        out.parent.mkdir(parents=True, exist_ok=True)
        run(["convert", str(source), str(out), *preset, "--for", "blender", "--overwrite"])
        written.append((frame, out))
    return written


def emission_material():
    """A Principled Volume (absorbing, no scattering) with Emission Color from the grid ``color``
    and Emission Strength 1: our radiance in scene-linear Rec.709, in 10⁴ cd/m² (the grid's unit,
    which EEVEE's half floats hold; Emission Strength 10⁴ gives cd/m² in Cycles)."""
    material = bpy.data.materials.get("incandescent emission") or bpy.data.materials.new(
        "incandescent emission"
    )
    material.use_nodes = True
    nodes, links = material.node_tree.nodes, material.node_tree.links
    nodes.clear()
    output = nodes.new("ShaderNodeOutputMaterial")
    volume = nodes.new("ShaderNodeVolumePrincipled")
    attribute = nodes.new("ShaderNodeAttribute")
    attribute.attribute_name = "color"
    volume.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)  # no scattering: σ_a = density
    volume.inputs["Emission Strength"].default_value = 1.0
    links.new(attribute.outputs["Color"], volume.inputs["Emission Color"])
    links.new(volume.outputs["Volume"], output.inputs["Volume"])
    attribute.location, volume.location, output.location = (-300, 0), (0, 0), (300, 0)
    return material


def emission_object(obj, frame_matrix, written):
    """A volume object showing the baked files (a sequence over their frames), placed as ``obj``."""
    name = f"{obj.name} emission"
    first_frame, first = written[0]
    volume = bpy.data.volumes.get(name) or bpy.data.volumes.new(name)
    volume.filepath = str(first)
    volume.is_sequence = len(written) > 1
    if volume.is_sequence:
        volume.frame_start, volume.frame_duration = first_frame, len(written)
    volume.materials.clear()
    volume.materials.append(emission_material())
    baked = bpy.data.objects.get(name) or bpy.data.objects.new(name, volume)
    if baked.name not in bpy.context.scene.collection.all_objects:
        bpy.context.scene.collection.objects.link(baked)
    baked.matrix_world = _matrix(frame_matrix)
    return baked


def _matrix(rows):
    from mathutils import Matrix

    return Matrix([tuple(row) for row in rows])


class INCANDESCENT_OT_bake_emission(_Reporting, bpy.types.Operator):
    """Bake incandescent's physical emission (vec3 grid "color") beside the cache and show it
    through a Principled Volume"""

    bl_idname = "incandescent.bake_emission"
    bl_label = "Bake physical emission"

    def run_operator(self, context):
        scene, obj = context.scene, context.active_object
        check_volume(obj)
        written = bake_frames(obj, scene)
        _, frame_matrix, _ = source_of(obj, written[0][0])
        baked = emission_object(obj, frame_matrix, written)
        obj.hide_render = True  # the baked object renders in its place
        folder = written[0][1].parent
        self.report({"INFO"}, f"incandescent: baked {len(written)} frames into {folder}; "
                    f"{baked.name!r} renders them ({obj.name!r} hidden from renders)")  # fmt: skip
        return {"FINISHED"}


class INCANDESCENT_PT_panel(bpy.types.Panel):
    bl_label = "incandescent"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "object"

    @classmethod
    def poll(cls, context):
        obj = context.active_object
        return obj is not None and (obj.type == "VOLUME" or fluid_domain(obj) is not None)

    def draw(self, context):
        layout = self.layout
        if context.active_object.type == "VOLUME":
            layout.prop(context.active_object, "incandescent_preset")
        layout.operator(INCANDESCENT_OT_render.bl_idname, icon="RENDER_STILL")
        layout.operator(INCANDESCENT_OT_render_animation.bl_idname, icon="RENDER_ANIMATION")
        layout.operator(INCANDESCENT_OT_bake_emission.bl_idname, icon="SHADING_RENDERED")


CLASSES = (
    IncandescentPreferences,
    INCANDESCENT_OT_render,
    INCANDESCENT_OT_render_animation,
    INCANDESCENT_OT_bake_emission,
    INCANDESCENT_PT_panel,
)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Object.incandescent_preset = bpy.props.EnumProperty(
        name="Source", description="How incandescent reads this volume's grids", items=PRESETS
    )


def unregister():
    del bpy.types.Object.incandescent_preset
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)

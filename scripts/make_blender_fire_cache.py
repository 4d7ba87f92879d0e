"""Bake a small Blender Mantaflow fire to an OpenVDB cache, headless.

Run with Blender's own Python (Debian 12's ``blender`` package is Blender 3.4.1)::

    blender -b --factory-startup --python scripts/make_blender_fire_cache.py -- OUTDIR \
        [--frames 20] [--resolution 64] [--compression BLOSC|ZIP|NONE] [--precision 16|32] \
        [--flow-type FIRE|BOTH] [--scene] [--cube] [--cfl 4] [--timesteps-max 4]

The scene: a gas domain 1 × 1 × 2 m (tall in z) at ``--resolution`` cells along its longest side
(64 → 32 × 32 × 64 voxels) and a small cube near the floor emitting FIRE (flame + fuel + heat),
baked for ``--frames`` frames. The cache lands in ``OUTDIR/data/fluid_data_####.vdb`` (one file
per frame with all grids: density, flame, fuel, heat, velocity, ...). Blender's defaults are
BLOSC compression and 16-bit (half float) precision.

Order matters in Blender 3.4: the flow object must be a FIRE (or BOTH) emitter *before* the
domain's cache type and format are set, otherwise the domain never allocates the fire grids
(flame, fuel, react) and the cache has smoke only.

This script is not imported by the package; it documents how ``tests/data/*.vdb`` was made.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import bpy  # type: ignore[import-not-found]  # Blender's own module


def parse_args() -> argparse.Namespace:
    argv = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else []
    parser = argparse.ArgumentParser(prog="make_blender_fire_cache.py")
    parser.add_argument("outdir", type=Path)
    parser.add_argument("--frames", type=int, default=20)
    parser.add_argument("--resolution", type=int, default=64, help="cells on the longest side")
    parser.add_argument("--compression", default="BLOSC", choices=["BLOSC", "ZIP", "NONE"])
    parser.add_argument("--precision", default="16", choices=["16", "32"])
    parser.add_argument(
        "--flow-type", default="FIRE", choices=["FIRE", "BOTH", "SMOKE"], help="BOTH: fire + smoke"
    )
    parser.add_argument(
        "--initial-velocity",
        type=float,
        default=None,
        help="the emitter pushes its gas up (+z) at this many m/s, and the domain has no buoyancy "
        "and no vorticity (a velocity-units probe)",
    )
    parser.add_argument(
        "--cube", action="store_true", help="a 1 m cube domain (n³ cells) instead of 1 × 1 × 2 m"
    )
    parser.add_argument("--cfl", type=float, default=None, help="the domain's CFL number")
    parser.add_argument(
        "--timesteps-max", type=int, default=None, help="sub-steps a frame, at most"
    )
    parser.add_argument(
        "--scene",
        action="store_true",
        help="also add a camera (64 × 96 pixels, 35 mm) and save the scene as OUTDIR/fire.blend "
        "(the Blender add-on's tests render its cache through that camera)",
    )
    return parser.parse_args(argv)


def clear_scene() -> None:
    bpy.ops.wm.read_factory_settings(use_empty=True)


def add_domain(cube: bool = False) -> bpy.types.Object:
    """A 1 × 1 × 2 m box standing on z = 0 (Blender is z-up); with ``cube``, 1 × 1 × 1 m."""
    height = 1.0 if cube else 2.0
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0.0, 0.0, height / 2))
    domain = bpy.context.active_object
    domain.name = "FireDomain"
    domain.scale = (1.0, 1.0, height)
    bpy.ops.object.transform_apply(location=False, rotation=False, scale=True)
    return domain


def add_fire_flow(flow_type: str = "FIRE") -> bpy.types.Object:
    """A small cube near the floor that emits fire (flame, fuel and heat), and with ``BOTH``
    smoke (density) as well."""
    bpy.ops.mesh.primitive_cube_add(size=0.25, location=(0.0, 0.0, 0.2))
    flow = bpy.context.active_object
    flow.name = "FireEmitter"
    modifier = flow.modifiers.new("Fluid", "FLUID")
    modifier.fluid_type = "FLOW"
    settings = modifier.flow_settings
    settings.flow_type = flow_type
    settings.flow_behavior = "INFLOW"
    settings.flow_source = "MESH"
    settings.fuel_amount = 1.5
    settings.temperature = 1.5
    settings.surface_distance = 1.0
    return flow


def probe_velocity(flow: bpy.types.Object, domain: bpy.types.Object, speed_m_s: float) -> None:
    """The emitter's gas starts at ``speed_m_s`` straight up; nothing else moves it."""
    settings = flow.modifiers["Fluid"].flow_settings
    settings.use_initial_velocity = True
    settings.velocity_coord = (0.0, 0.0, speed_m_s)
    settings.temperature = 0.0
    domain_settings = domain.modifiers["Fluid"].domain_settings
    domain_settings.alpha = 0.0  # density buoyancy
    domain_settings.beta = 0.0  # heat buoyancy
    domain_settings.vorticity = 0.0


def configure_domain(domain: bpy.types.Object, args: argparse.Namespace) -> None:
    modifier = domain.modifiers.new("Fluid", "FLUID")
    modifier.fluid_type = "DOMAIN"
    settings = modifier.domain_settings
    settings.domain_type = "GAS"
    settings.resolution_max = args.resolution
    settings.use_adaptive_domain = False
    settings.use_noise = False
    if args.cfl is not None:
        settings.cfl_condition = args.cfl
    if args.timesteps_max is not None:
        settings.timesteps_max = args.timesteps_max
    # Cache settings last (after the FIRE flow exists), see the module docstring.
    settings.cache_directory = str(args.outdir.resolve())
    settings.cache_type = "ALL"
    settings.cache_data_format = "OPENVDB"
    settings.openvdb_cache_compress_type = args.compression
    settings.openvdb_data_depth = args.precision
    settings.cache_frame_start = 1
    settings.cache_frame_end = args.frames


def add_camera() -> bpy.types.Object:
    """A camera three metres off, looking at the domain's lower half; a tall 64 × 96 image (the
    sensor width then spans its height: Blender's Auto sensor fit)."""
    data = bpy.data.cameras.new("Camera")
    data.lens = 35.0
    camera = bpy.data.objects.new("Camera", data)
    bpy.context.scene.collection.objects.link(camera)
    camera.location = (3.2, -4.1, 1.6)
    camera.rotation_euler = (1.45, 0.0, 0.66)
    scene = bpy.context.scene
    scene.camera = camera
    scene.render.resolution_x, scene.render.resolution_y = 64, 96
    scene.render.resolution_percentage = 100
    return camera


def bake(domain: bpy.types.Object, frames: int) -> None:
    scene = bpy.context.scene
    scene.frame_start = 1
    scene.frame_end = frames
    bpy.context.view_layer.objects.active = domain
    domain.select_set(True)
    with bpy.context.temp_override(active_object=domain, object=domain):
        result = bpy.ops.fluid.bake_all()
    if result != {"FINISHED"}:
        raise SystemExit(f"fluid.bake_all returned {result}")


def main() -> None:
    args = parse_args()
    args.outdir.mkdir(parents=True, exist_ok=True)
    clear_scene()
    domain = add_domain(args.cube)
    flow = add_fire_flow(args.flow_type)  # before the domain's cache settings
    configure_domain(domain, args)
    if args.initial_velocity is not None:
        probe_velocity(flow, domain, args.initial_velocity)
    if args.scene:
        add_camera()
    began = time.perf_counter()
    bake(domain, args.frames)
    print(f"BAKE_SECONDS {time.perf_counter() - began}")  # benchmarks/fire_vs_mantaflow.py
    if args.scene:
        bpy.ops.wm.save_as_mainfile(filepath=str((args.outdir / "fire.blend").resolve()))
    written = sorted(args.outdir.rglob("*.vdb"))
    print(f"baked {len(written)} .vdb files under {args.outdir}")
    for path in written:
        print(f"  {path} ({path.stat().st_size} bytes)")


if __name__ == "__main__":
    main()

"""The command line's options, each declared once, and the scene overrides made from them.

A :class:`Flag` is one option (or argument) — its parameter name, type, help, default and the
scene key it sets (``"render.width"``: the flag → scene map; ``tests/cli/test_cli.py`` checks every
key against the schema) —, declared in one group per concern (volume, emitters, camera, film,
motion blur, integrator, display, output, limits, cluster). A command is its groups
(:func:`command`); a flag whose default or help differs in one command says so there
(:meth:`Flag.but`). :func:`overrides` turns the flags given into the nested scene keys that
``render`` and ``animate`` lay over a scene file. Defaults in [brackets] are read from the
settings classes (``RenderSettings``, ``DisplaySettings``, ``Camera``).
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Annotated, Any

import typer
from rich.console import Console
from rich.markup import escape

from incandescent.camera import Camera
from incandescent.imaging import DisplaySettings
from incandescent.renderer import RenderSettings
from incandescent.renderer.backends import BACKENDS
from incandescent.scenes import SCENES

console = Console(stderr=True)


def fail(message: str) -> typer.Exit:
    """Print ``message`` as one error (no markup interpreted, no wrapping); exit status 2."""
    console.print(f"[bold red]error:[/] {escape(message)}", highlight=False, soft_wrap=True)
    return typer.Exit(code=2)


def say(message: str) -> None:
    """Print ``message`` verbatim (paths may hold [brackets]) without wrapping."""
    console.print(message, highlight=False, markup=False, soft_wrap=True)


# --- flag values that are not plain numbers or words --------------------------------------------


def _vector(text: str, flag: str) -> tuple[float, ...]:
    try:
        values = tuple(float(p) for p in text.split(","))
    except ValueError:
        values = ()
    if len(values) != 3:
        raise fail(f"{flag} must be three numbers X,Y,Z in m; got {text!r}")
    return values


def _pair(expected: str) -> Callable[[str, str], list[float]]:
    """A parser of ``A:B`` → [A, B]; the error names the flag and ``expected``."""

    def parse(text: str, flag: str) -> list[float]:
        low, sep, high = text.partition(":")
        try:
            if not sep:
                raise ValueError
            return [float(low), float(high)]
        except ValueError:
            raise fail(f"{flag} must be {expected}; got {text!r}") from None

    return parse


def _sun(text: str, flag: str) -> list[dict]:
    """``X,Y,Z,LUX`` → one directional light toward (X, Y, Z) giving LUX on a plane facing it."""
    try:
        values = tuple(float(p) for p in text.split(","))
    except ValueError:
        values = ()
    if len(values) != 4:
        raise fail(f"{flag} must be X,Y,Z,LUX (direction toward the sun, illuminance in lux); "
                   f"got {text!r}")  # fmt: skip
    return [{"type": "directional", "direction": list(values[:3]), "illuminance_lux": values[3]}]


def _sensor(text: str) -> dict:
    """``--sensor``: a shipped sensitivity's name, or a .toml/.json file's ``[sensor]`` table
    (or the whole file)."""
    from incandescent.io.textfiles import parse_json, parse_toml

    path = Path(text)
    if path.suffix.lower() not in (".toml", ".json"):
        return {"sensitivity": text}
    try:
        body = path.read_text()
    except OSError as error:
        raise fail(f"--sensor {text}: cannot read it ({error.strerror})") from None
    try:
        data = (parse_toml if path.suffix.lower() == ".toml" else parse_json)(body, path)
    except ValueError as error:
        raise fail(str(error)) from None
    table = data.get("sensor", data) if isinstance(data, dict) else None
    if not isinstance(table, dict):
        raise fail(f"--sensor {text}: expected a table of sensor keys")
    return table


def _number_or_name(text: str, flag: str) -> float | str:
    """A number (a constant), else a grid's name."""
    try:
        return float(text)
    except ValueError:
        return text


def _species(text: str, flag: str) -> dict[str, float | str]:
    """``Na=0.02,Li=lithium`` → {"Na": 0.02, "Li": "lithium"} (a number or a grid name)."""
    out: dict[str, float | str] = {}
    for item in filter(None, (part.strip() for part in text.split(","))):
        name, sep, value = item.partition("=")
        if not sep or not name or not value:
            raise fail(f"{flag} entries must be NAME=FRACTION or NAME=GRID; got {item!r}")
        try:
            out[name] = float(value)
        except ValueError:
            out[name] = value
    return out


def _options(text: str, flag: str) -> dict[str, float]:
    """``ignition=1.2,max_temp=2.5`` → {"ignition": 1.2, "max_temp": 2.5}."""
    out: dict[str, float] = {}
    for item in filter(None, (part.strip() for part in text.split(","))):
        name, sep, value = item.partition("=")
        try:
            out[name] = float(value) if sep and name else float("x")
        except ValueError:
            raise fail(f"{flag} entries must be NAME=NUMBER; got {item!r}") from None
    return out


def integrator_name(name: str | None, brightness: str | None) -> str | None:
    """``--integrator NAME``, or ``--brightness physical|paper`` read as one (None: neither)."""
    from incandescent.config.legacy import BRIGHTNESS_INTEGRATORS

    if brightness is not None and brightness not in BRIGHTNESS_INTEGRATORS:
        raise fail(f"--brightness must be physical or paper; got {brightness!r}")
    by_brightness = None if brightness is None else BRIGHTNESS_INTEGRATORS[brightness]
    if name is not None and by_brightness is not None and name != by_brightness:
        raise fail(f"--integrator {name} and --brightness {brightness} disagree; give one")
    return name or by_brightness


def _nonnegative(flag: str) -> Callable[[float | None], float | None]:
    """A typer callback refusing a negative or non-finite value of ``flag`` as it is parsed."""

    def check(value: float | None) -> float | None:
        if value is not None and not 0.0 <= value < float("inf"):  # also refuses nan
            raise fail(f"{flag} must be a finite number >= 0; got {value!r}")
        return value

    return check


def _deprecated(old: str, new: str) -> Callable[[Any], Any]:
    """A typer callback printing one warning line when the old spelling ``old`` is used."""

    def warn(value: Any) -> Any:
        if value is not None:
            say(f"warning: {old} is deprecated and will be removed; use {new}")
        return value

    return warn


# --- options: each declared once ------------------------------------------------------------


@dataclass(frozen=True)
class Flag:
    """One option (or argument): its parameter ``name``, type, help, default, and the scene key
    it sets (``key``: "section.field…"; None: not a scene key), its text read by ``parse``."""

    name: str
    kind: Any
    help: str
    key: str | None = None
    parse: Callable[[Any, str], Any] | None = None
    default: Any = None
    decls: tuple[str, ...] = ()
    argument: bool = False
    extra: dict = field(default_factory=dict)  # more typer.Option arguments

    @property
    def flag(self) -> str:
        return self.decls[0].split("/")[0] if self.decls else "--" + self.name.replace("_", "-")

    def but(self, **changes: Any) -> Flag:
        """This flag with another default or help for one command (stated there, deliberately)."""
        return replace(self, **changes)

    def parameter(self) -> inspect.Parameter:
        make = typer.Argument if self.argument else typer.Option
        kind = self.kind if self.default is not None else self.kind | None
        info = make(*self.decls, help=self.help, **self.extra)
        keyword = inspect.Parameter.KEYWORD_ONLY
        return inspect.Parameter(
            self.name, keyword, default=self.default, annotation=Annotated[kind, info]
        )


RS, DS, CAMERA_FOV = RenderSettings, DisplaySettings, Camera.fov_deg
BACKEND_CHOICES = " | ".join(("auto", *BACKENDS))

# fmt: off
AXES = Flag("axes", str, "Order of the stored array axes, e.g. zyx (files that do not say) "
            "[xyz].", "volume.axes")
VOLUME = (
    Flag("absorption", float, "Constant absorption κ in 1/m [the file's absorption grid, else "
         "1/L where T >= 500 K, L = the box's largest side].", "volume.absorption"),
    Flag("voxel_size", float, "Voxel side in m [file's, else largest side 1 m].",
         "volume.voxel_size_m"),
    Flag("temperature_grid", str, "Name of the temperature grid [temperature, heat, temp or T].",
         "volume.grids.temperature"),
    Flag("absorption_grid", str, "Name of the absorption grid, κ in 1/m [absorption] (a --for "
         "blender file's: density).", "volume.grids.absorption"),
    Flag("preset", str, "Source preset: blender | houdini | embergen | openfoam.",
         "volume.preset"),
    Flag("preset_options", str, "The preset's options NAME=NUMBER, comma-separated (e.g. "
         "ignition=1.2,max_temp=2.5: a Blender domain's Flame Ignition and Maximum Temperature).",
         "volume.preset_options", _options),
    Flag("up_axis", str, "The source's up axis: y | z [preset's, else y].", "volume.up_axis"),
    AXES,
    Flag("resolution", int, "Voxels along the longest side of a VTK/OpenFOAM mesh resampled "
         "onto voxels [about 2 per cell, 64–256].", "volume.resolution"),
    Flag("upres", int, "Up-resolve a simulated frame 2, 3 or 4× with sub-grid turbulence from "
         "its velocity grid (wavelet turbulence, Kim et al. 2008).", "volume.upres"),
    Flag("offset", float, "Temperature remap: T = (raw − offset)·scale [0].",
         "volume.temperature.offset"),
    Flag("scale", float, "Temperature remap scale, K per raw unit [1].",
         "volume.temperature.scale"),
    Flag("cutoff", float, "Voxels below this many K are vacuum [0].",
         "volume.temperature.cutoff_K"),
    Flag("temperature_range", str, "LOW:HIGH — map a normalised 0..1 field linearly to LOW..HIGH "
         "K.", "volume.temperature.range", _pair("LOW:HIGH in K (e.g. 800:2200)")),
)
EMITTERS = (
    Flag("species", str, "Emitting species, NAME=FRACTION or NAME=GRID, comma-separated (e.g. "
         "Na=0.02,Li=lithium); lines from the shipped table or --line-table.", "volume.species",
         _species),
    Flag("line_table", Path, "Species line table (.csv/.toml) [shipped].", "emission.line_table",
         lambda path, flag: str(path)),
)
LIGHTING = (
    Flag("scattering", str, "Scattering σ_s: a constant in 1/m or a grid's name [none].",
         "volume.scattering", _number_or_name),
    Flag("albedo", float, "Scattering from the albedo σ_s/(σ_s + κ), 0 <= A < 1.",
         "volume.albedo"),
    Flag("scattering_alpha", float, "Spectral law of the scattering σ_s,λ = σ_s·(550 nm/λ)^β "
         "with --spectral-bins: β in [0, 4] (4: Rayleigh) [0: grey].", "volume.scattering_alpha"),
    Flag("phase_g", str, "Henyey–Greenstein asymmetry g, -1 < g < 1 (> 0 forward), or a "
         "grid's name [0].", "volume.phase_g", _number_or_name),
    Flag("sun", str, "A sun: X,Y,Z,LUX — direction toward it and illuminance in lux (a "
         "single_scattering render).", "light", _sun),
    Flag("sun_temperature", float, "The sun's blackbody temperature in K [5778]."),
    Flag("sun_diameter", float, "The sun's angular diameter in degrees (0.53: the real sun's; "
         "soft shadows, 16 shadow directions) [0: a point, sharp shadows]."),
    Flag("environment", str, "A sky: FILE.exr (an HDR lat-long map, RGB × 1 = radiance in "
         "cd/m²) or a uniform luminance in cd/m²."),
    Flag("fire_light", bool, "The volume's own emission lights its smoke (sampled by power; a "
         "single_scattering render).", default=False),
    Flag("spp", int, "Monte Carlo samples per scattering sample of a camera ray (the fire's "
         "light, a sky, paths of --max-bounces >= 2) [4].", "integrator.spp"),
    MAX_BOUNCES := Flag("max_bounces", int, "Orders of scattering: 0 (no light scattered: "
                        "emission–absorption, lights dropped) | 1 (single scattering) | N >= 2 "
                        "(multiple scattering, Monte Carlo) [1 with lights, else 0]."),
    IN_SCATTER := Flag("in_scatter", str, "How the fire's light and skies reach the smoke in "
                       "single scattering: per-sample (estimated at every sample, --spp) | cache "
                       "(estimated once per render at the voxel centres for this camera, "
                       "--cache-pairs each, and interpolated: faster, slightly biased) "
                       "[per-sample].", "integrator.in_scatter"),
    Flag("cache_pairs", int, "Samples per voxel of --in-scatter cache [16].",
         "integrator.cache_pairs"),
    Flag("cache_voxels", int, "Voxels per side of --in-scatter cache's cells: 1 | 2 (8× fewer "
         "estimates, interpolated over twice the distance) [1].", "integrator.cache_voxels"),
)
CAMERA = (
    Flag("eye", str, "Camera position X,Y,Z in m [three-quarter view].", "camera.eye", _vector),
    Flag("target", str, "Point looked at, X,Y,Z in m [centre of the gas].", "camera.target",
         _vector),
    Flag("fov", float, f"Vertical field of view in degrees [{CAMERA_FOV:g}].", "camera.fov_deg"),
    Flag("up", str, "Camera up direction X,Y,Z (its roll) [0,1,0].", "camera.up", _vector),
    Flag("projection", str, "perspective | orthographic [perspective].", "camera.projection"),
    Flag("ortho_height", float, "Height of an orthographic view in m [1].",
         "camera.ortho_height_m"),
)
FOR_TARGET = Flag("for_target", str, "Write the .vdb for an application: blender (z up, "
                  "density, temperature K, flame, velocity, color) | houdini (y up, vel, "
                  "emission); color/emission is our emission baked (linear Rec.709).",
                  decls=("--for",))
WIDTH = Flag("width", int, f"Image width in pixels [{RS.width}].", "render.width")
HEIGHT = Flag("height", int, f"Image height in pixels [{RS.height}].", "render.height")
FPS = Flag("fps", float, f"Frames per second, for the shutter [{RS.fps:g}].", "render.fps")
FILM = (
    WIDTH,
    HEIGHT,
    Flag("step", float, f"Ray-march step in voxels [{RS.step_voxels:g}].", "render.step_voxels"),
    Flag("supersample", int, f"N for N×N rays per pixel [{RS.supersample}].",
         "render.supersample"),
    Flag("seed", int, f"Jitter seed [{RS.seed}].", "render.seed"),
    Flag("layout", str, "Grid layout: auto | dense | sparse (occupied 8³ bricks only) "
         f"[{RS.layout}].", "render.layout"),
)
BLUR = (
    Flag("shutter", str, "Motion blur: shutter OPEN:CLOSE in frames around each frame's instant, "
         "e.g. -0.25:0.25 (a 180° shutter) [off; needs a velocity grid].", "render.shutter",
         _pair("OPEN:CLOSE in frames (e.g. -0.25:0.25)")),
    Flag("velocity_grid", str, "Velocity grid for motion blur [velocity, vel, v].",
         "volume.grids.velocity"),
    Flag("velocity_units", str, "Velocity grid units: m/s | voxels/frame [m/s].",
         "volume.velocity_units"),
    Flag("velocity_scale", float, "Factor on the velocity grid (Blender's), >= 0 [1].",
         "volume.velocity_scale", extra={"callback": _nonnegative("--velocity-scale")}),
)
BRIGHTNESS = Flag("brightness", str, "physical (absolute Planck, emission–absorption) | paper "
                  "(the 2011 method).")
INTEGRATOR = (
    BRIGHTNESS,
    Flag("integrator", str, "emission_absorption | paper2011 | single_scattering (the "
         "[integrator] type) [emission_absorption; single_scattering with lights].",
         "integrator.type"),
    Flag("spectral_bins", int, "N spectral bins for soot's κ_λ and the scattering's σ_s,λ "
         "(emission, every light, all orders; 0: grey) [0].",
         "integrator.spectral_bins"),
    Flag("sodium", float, "Constant sodium fraction 0..1 (species Na)."),
    Flag("paper_exponent", float, "Paper mode: brightness ∝ T^exponent [1.5].",
         "integrator.exponent"),
)
EXPOSURE = Flag("exposure", float, f"Exposure compensation in EV [{DS.exposure_ev:g}].",
                "display.exposure_ev")
DISPLAY = (
    EXPOSURE.but(help=f"Exposure compensation in EV (PNG) [{DS.exposure_ev:g}]."),
    Flag("auto_exposure", bool, "Auto exposure (PNG) [on].", "display.auto_exposure",
         decls=("--auto-exposure/--no-auto-exposure",)),
    Flag("tonemap", str, f"PNG tone map: clip | reinhard | filmic [{DS.tonemap}].",
         "display.tonemap"),
    Flag("space", str, "RGB space: srgb | rec2020 | display_p3 | acescg.", "render.space"),
)
BACKEND = Flag("backend", str, f"{BACKEND_CHOICES} [auto; env INCANDESCENT_BACKEND].",
               "output.backend")
OVERWRITE = Flag("overwrite", bool, "Replace existing output files.", "output.overwrite",
                 decls=("--overwrite",))
OUTPUT = (
    Flag("output", Path, "Output image: .exr (HDR) or .png.", "output.path",
         decls=("--output", "-o")),
    Flag("stats", Path, "Write render statistics (JSON) to this file.", "output.stats"),
    OVERWRITE,
    BACKEND,
)
LIMITS = (
    Flag("max_memory", float, "Refuse work estimated to need more memory, GiB [the memory "
         "available now]."),
    Flag("max_samples", float, "Refuse renders estimated to take more ray-march samples [1e11]."),
)
CLUSTER = (
    Flag("workers", int, "Render on a local Dask cluster of N worker processes (at most 2 per core "
         "and one per 512 MiB of memory) [in-process]."),
    Flag("scheduler", str, "Render on an existing Dask cluster: tcp://HOST:PORT, which must answer "
         "within 20 s ($INCANDESCENT_SCHEDULER_TIMEOUT) [$INCANDESCENT_SCHEDULER]."),
)
AS_JSON = Flag("as_json", bool, "Print one JSON object (for scripts).", default=False,
               decls=("--json",))
SIZE = Flag("size", int, "Grid resolution of the scene, voxels per side.")
FRAMES = Flag("frames", int, "Number of frames.")
# fmt: on


class Given:
    """The values a command was called with, by parameter name, and the flags they came from."""

    def __init__(self, values: dict[str, Any], flags: tuple[Flag, ...]) -> None:
        self.values, self.flags = values, flags

    def __getattr__(self, name: str) -> Any:
        try:
            return self.values[name]
        except KeyError:
            raise AttributeError(name) from None


def command(*groups: Flag | tuple) -> Callable[[Callable[[Given], None]], Callable]:
    """``body(given)`` as a function whose parameters are the flags of ``groups`` (for
    ``app.command``, which reads its signature)."""
    flags = tuple(_flat(groups))

    def register(body: Callable[[Given], None]) -> Callable:
        def command(**values: Any) -> None:
            body(Given(values, flags))

        command.__name__, command.__doc__ = body.__name__, body.__doc__
        signature = inspect.Signature([f.parameter() for f in flags])
        command.__signature__ = signature  # type: ignore[attr-defined]
        return command

    return register


def _flat(groups: tuple) -> Iterator[Flag]:
    for group in groups:
        yield from ((group,) if isinstance(group, Flag) else _flat(group))


#: ``--max-bounces`` → the integrator that scatters that many times (2 and more: multiple).
BOUNCE_INTEGRATORS = {0: "emission_absorption", 1: "single_scattering", 2: "multiple_scattering"}


def _environment(text: str) -> dict:
    """``--environment FILE.exr|LUMINANCE`` as a ``[[light]]`` table."""
    try:
        luminance = float(text)
    except ValueError:
        return {"type": "environment", "map": str(Path(text).expanduser().absolute())}
    return {"type": "environment", "luminance_cd_m2": luminance}


def _bounces(bounces: int | None, out: dict) -> None:
    """``--max-bounces N`` as the integrator type (and its ``max_bounces`` from 2 on); 0 also
    drops the lights (today's image)."""
    if bounces is None:
        return
    if bounces < 0:
        raise fail(f"--max-bounces must be 0 (no scattering), 1 (single) or more; got {bounces}")
    kind = BOUNCE_INTEGRATORS[min(bounces, 2)]
    table = out.setdefault("integrator", {})
    if table.get("type") not in (None, kind):
        raise fail(f"--max-bounces {bounces} and integrator {table['type']!r} disagree; give one")
    table["type"] = kind
    if bounces >= 2:
        table["max_bounces"] = bounces
    if bounces == 0:  # today's image: no lights, nothing to sample
        out["light"] = []
        for key in ("spp", "in_scatter", "cache_pairs", "cache_voxels"):
            table.pop(key, None)


def overrides(given: Given) -> dict:
    """Nested scene keys for the flags that were given (the flag → scene map is the flags' keys);
    ``--brightness`` is read as an integrator and ``--sodium`` as species Na."""
    out: dict = {}
    for flag in given.flags:
        value = given.values.get(flag.name)
        if flag.key is None or value is None:
            continue
        *sections, last = flag.key.split(".")
        table = out
        for name in sections:
            table = table.setdefault(name, {})
        table[last] = flag.parse(value, flag.flag) if flag.parse else value
    if "brightness" in given.values:
        kind = integrator_name(given.values.get("integrator"), given.values["brightness"])
        out.setdefault("integrator", {})["type"] = kind
    if given.values.get("fire_light"):
        out.setdefault("light", []).append({"type": "emission"})
    if given.values.get("environment") is not None:
        out.setdefault("light", []).append(_environment(given.values["environment"]))
    _bounces(given.values.get("max_bounces"), out)
    if given.values.get("sensor") is not None:
        out["sensor"] = {**_sensor(given.values["sensor"]), **out.get("sensor", {})}
    if given.values.get("sun_temperature") is not None:
        if given.values.get("sun") is None:
            raise fail("--sun-temperature needs --sun X,Y,Z,LUX")
        out["light"][0]["temperature_K"] = given.values["sun_temperature"]
    if given.values.get("sun_diameter") is not None:
        if given.values.get("sun") is None:
            raise fail("--sun-diameter needs --sun X,Y,Z,LUX")
        out["light"][0]["angular_diameter_deg"] = given.values["sun_diameter"]
    if given.values.get("sodium") is not None:
        species = out.setdefault("volume", {}).setdefault("species", {})
        if "Na" in species:
            raise fail("--sodium is the fraction of species Na, also given in --species; give one")
        species["Na"] = given.values["sodium"]
    return out


#: The built-in scenes (``incandescent.scenes.SCENES``) and the paper's plate video.
DEMOS = (*SCENES, "plate")
#: Image size of ``demo plate`` and of ``simulate --render`` (its frames are tall).
PLATE_SIZE, FIRE_SIZE = (320, 240), (320, 480)

# --- each command's flags, in the order its help lists them ---------------------------------

# fmt: off
SCENE_SOURCE = Flag("source", Path, "A volume file (.npy .npz .vdb .nvdb .h5 .hdf5 .nc) or a "
                    "scene file (.toml, .json) whose values the options below override.",
                    default=..., argument=True)
DENOISE = Flag("denoise", bool, "Denoise the image with Intel Open Image Denoise (a preview: "
                "no longer an unbiased estimate; needs incandescent[denoise]).", "output.denoise",
                default=False)
ACCUMULATE = (
    Flag("batches", int, "Render N batches of samples (seeds apart), averaged, the output "
         "written after each [1].", "output.batches"),
    Flag("time_budget", float, "Render batches while the next fits in this many seconds (at "
         "least one; --batches N the most), averaged, the output written after each.",
         "output.time_budget_s"),
    Flag("accumulate", bool, "Continue the output .exr: average more batches into it (the same "
         "scene and settings, seed aside).", "output.accumulate", default=False),
)
SENSOR = (
    Flag("sensor", str, "Expose a raw image through a camera sensor: a shipped one "
         "(nikon_d5100) or a .toml/.json file of [sensor] keys; the output .dng|.tiff|.npy."),
    Flag("exposure_time", float, "The sensor's exposure time in s [1e-4].", "sensor.exposure_s"),
)
PYROMETRY = (
    Flag("raw", Path, "A raw image: .dng .tiff .npy (its JSON sidecar beside it).", default=...,
         argument=True),
    Flag("output", Path, "Temperature map: .exr (RGB = T in K; channels T, sigma_T, tau_550, "
         "usable).", default=..., decls=("--output", "-o")),
    SENSOR[0].but(help="The camera: a shipped one (nikon_d5100) or a .toml/.json of [sensor] "
                  "keys (width_px/height_px: the size the raw file must have) [the raw file's "
                  "sidecar]."),
    Flag("alpha", float, "Soot's spectral exponent α of ε ∝ λ^−α (0: a grey body).",
         default=1.39),
    Flag("calibration", float, "This camera's measured / modelled signal (from a blackbody "
         "image): also soot's τ₅₅₀ and the thick-soot T."),
    Flag("blackbody", Path, "A raw image of a blackbody filling the view, with the same "
         "camera: the calibration (needs --blackbody-k)."),
    Flag("blackbody_k", float, "The blackbody's temperature in K."),
    Flag("max_sigma", float, "Largest σ_T in K of a usable pixel.", default=50.0),
    OVERWRITE.but(key=None, default=False, help="Replace an existing output."),
)
LAYERS = Flag("layers", bool, "EXR layers emission, scatter.direct, scatter.indirect and one per "
               "light (a scattering render; 3 + lights renders).", "output.layers", default=False)
RENDER = (SCENE_SOURCE, OUTPUT, LAYERS, DENOISE, ACCUMULATE, SENSOR, FILM, VOLUME, EMITTERS,
          LIGHTING, CAMERA, INTEGRATOR, DISPLAY, BLUR, FPS, LIMITS)
DEMO = (
    Flag("name", str, f"Scene: {', '.join(DEMOS)}.", default="fire", argument=True),
    Flag("output", Path, "Output: .png/.exr for images (default NAME.png); .mp4, .gif or a "
         "folder of PNG frames for plate (default plate.mp4).", decls=("--output", "-o")),
    SIZE.but(help="Grid resolution (plume/sparse/soot 128, sphere 64, 96)."),
    WIDTH.but(help=f"Image width ({RS.width}; plate {PLATE_SIZE[0]})."),
    HEIGHT.but(help=f"Image height ({RS.height}; plate {PLATE_SIZE[1]})."),
    FRAMES.but(default=250, help="plate: number of frames."),
    MAX_BOUNCES.but(help="campfire, explosion: orders of their smoke's scattering, 0 (dark "
                    "smoke: emission–absorption) | 1 | N >= 2 [1]."),
    IN_SCATTER.but(help="campfire, explosion: their fire's light and sky estimated at every "
                   "sample (per-sample) or from the per-camera cache (cache, 16 samples a "
                   "voxel: faster, slightly biased) [per-sample]."),
    BRIGHTNESS.but(default="physical", help="physical | paper (the 2011 method)."),
    BACKEND.but(default="auto", help=BACKEND_CHOICES + "."),
    OVERWRITE.but(default=False, decls=(), help="Replace an existing output (plate: and render "
                  "every frame again)."),
    LIMITS,
)
INFO = (
    Flag("path", Path, "A volume file (.npy .npz .vdb .nvdb .h5 .hdf5 .nc), or a folder "
         "written by simulate (its per-frame diagnostics).", default=...,
         argument=True),
    AXES,
    AS_JSON,
)
CONVERT = (
    SCENE_SOURCE.but(help="A volume file (any readable format) or a scene file."),
    Flag("output", Path, "Output: .npz (dense, placed) or .vdb (sparse).", default=...,
         argument=True),
    VOLUME,
    FOR_TARGET,
    EMITTERS,
    OVERWRITE.but(key=None, default=False, help="Replace an existing output."),
    LIMITS[0],
)
ANIMATE = (
    Flag("source", str, "Volume files of a sequence — a glob ('cache/*.npz') or a #### frame "
         "pattern — or a scene file (.toml, .json) whose [volume] path is one; the options "
         "below override it.", default=..., argument=True),
    Flag("output", Path, "Output .mp4, .gif, or a folder for PNG frames.", default=...,
         decls=("--output", "-o")),
    WIDTH.but(help="Frame width in pixels [640]."),
    HEIGHT.but(help="Frame height in pixels [360]."),
    FILM[2:], VOLUME, EMITTERS, LIGHTING, CAMERA,
    Flag("orbit", float, "Orbit the camera this many degrees about the vertical axis over the "
         "video.", default=0.0),
    INTEGRATOR,
    EXPOSURE.but(help="Exposure compensation in EV over the fixed exposure [0]."),
    DISPLAY[1:],
    FPS.but(help="Frames per second of the video (and of the shutter) [25]."),
    BACKEND,
    OVERWRITE.but(key=None, default=False, decls=(), help="Replace an existing video and render "
                  "every frame again."),
    BLUR, CLUSTER, LIMITS,
)
SIMULATE = (
    Flag("preset_name", str, "candle | torch | campfire | explosion | pool.", default=...,
         argument=True, extra={"metavar": "PRESET"}),
    Flag("pool", str, "The pool preset's diameter (m), heat release rate (kW) and fuel "
         "(methane | propane | heptane) [0.5:100:methane].", extra={"metavar": "D:Q[:FUEL]"}),
    Flag("output", Path, "Folder for the frames (fire_####).", default=...,
         decls=("--output", "-o")),
    Flag("resolution", int, "Cells along the domain's longest side.", default=64),
    FRAMES.but(default=48, help="Frames to simulate."),
    Flag("settings_file", Path, "A .toml/.json of FireSettings fields over the preset's.",
         decls=("--settings",)),
    Flag("seed", int, "Seed of the sources' turbulence [preset's: 0]."),
    Flag("wind", float, "A steady wind along +x in m/s (settings key wind_m_s) [0: still air].",
         extra={"metavar": "M/S"}),
    Flag("frame_format", str, "Frame files: npz | vdb.", default="npz", decls=("--format",)),
    FOR_TARGET.but(help="Also write each frame for an application, into OUTPUT/TARGET/: "
                   "blender | houdini (needs --format vdb; see convert --for)."),
    BACKEND.but(default="auto", help=BACKEND_CHOICES + "."),
    Flag("render_to", Path, "Also render the frames to this .mp4/.gif/folder.",
         decls=("--render",)),
    Flag("upres", int, "--render each frame up-resolved 2, 3 or 4× with sub-grid turbulence "
         "(wavelet turbulence, Kim et al. 2008); the frames stay as simulated."),
    WIDTH.but(default=FIRE_SIZE[0], help="Rendered frame width."),
    HEIGHT.but(default=FIRE_SIZE[1], help="Rendered frame height."),
    CLUSTER[0].but(help="--render on a local Dask cluster of N workers."),
    CLUSTER[1].but(help="--render on an existing Dask cluster."),
    EXPOSURE.but(help="--render with this fixed exposure (EV) [auto: from the middle frame, "
                 "after the simulation]; each frame is then rendered as soon as it is written "
                 "(with --workers/--scheduler on the cluster, while the next is simulated)."),
    OVERWRITE.but(default=False, decls=(), help="Start again even if OUTPUT holds another run."),
    LIMITS[0],
)
VIEW = (
    Flag("source", str, "What render or animate takes: a volume file, a sequence ('cache/"
         "fire_####.vdb' or a glob), a scene file (.toml, .json), or a folder written by "
         "simulate; the options below set the first view.", default=..., argument=True),
    Flag("port", int, "Port to listen on [a free one].", default=0),
    Flag("host", str, "Address to listen on; anything but 127.0.0.1 lets other machines in "
         "(the token still guards it).", default="127.0.0.1"),
    Flag("no_browser", bool, "Print the URL only; do not open a browser.", default=False,
         decls=("--no-browser",)),
    FILM[:3], VOLUME, EMITTERS, LIGHTING[:5], LIGHTING[9], CAMERA, INTEGRATOR[1:3], DISPLAY,
    BACKEND, LIMITS,
)
BENCH = (
    AS_JSON.but(help="Print the results as JSON."),
    Flag("scenes", str, "Comma-separated scenes: plume, sparse, soot.",
         default="plume,sparse,soot"),
    SIZE.but(default=256, help="Grid resolution of the scenes."),
    Flag("pixels", int, "Image width and height in pixels [512]."),
    Flag("resolution", int, "Deprecated spelling of --pixels.",
         extra={"hidden": True, "callback": _deprecated("bench --resolution", "--pixels")}),
    Flag("repeat", int, "Timed repetitions per case (median reported).", default=5),
    Flag("reference", bool, "Include the NumPy reference (at 1/4 resolution).", default=True),
    Flag("cold", bool, "Also time frames that each render a new volume (cold).", default=False,
         decls=("--cold",)),
    Flag("fire", str, "Time the fire solver instead, at these grid sizes (e.g. 64,128): the "
         "explosion at CFL 4, each pressure preconditioner side by side."),
)
RECONSTRUCT = (
    Flag("views", list[Path], "EXR radiance views (absolute linear RGB, as render writes them).",
         default=..., argument=True),
    Flag("cameras", Path, "Their cameras: a .toml ([[camera]] tables) or .json list, one per "
         "view in order (eye, target, up, fov_deg…; width/height: the film the view must have); "
         "or a scene file's [camera] for one view.",
         default=..., decls=("--cameras", "-c")),
    Flag("output", Path, "The temperature volume: .npz or .vdb (beside it NAME.residual-K.exr "
         "per view, NAME.loss.json, and while running NAME.checkpoint.npz).", default=...,
         decls=("--output", "-o")),
    Flag("like", Path, "A volume file whose grid, box and absorption to use (its T ignored)."),
    Flag("bounds", str, "The box x0,y0,z0:x1,y1,z1 in m (without --like)."),
    SIZE.but(default=32, help="Voxels along the box's longest side (without --like)."),
    Flag("absorption", float, "Constant absorption κ in 1/m (without --like).", default=10.0),
    Flag("iterations", int, "L-BFGS-B iterations per level.", default=100),
    Flag("levels", int, "Coarse-to-fine levels (1: the grid only; 3: 1/4, 1/2, 1).", default=3),
    Flag("tv", float, "Total-variation weight, relative to the data term.", default=3e-3),
    Flag("tv_eps", float, "The TV's smoothing ε in K per voxel: a smoothness prior for steps "
         "below it, edge-preserving above.", default=100.0, decls=("--tv-eps",)),
    Flag("tv_continuation", str, "TV weights to relax to at the finest level, one after "
         "another, --iterations each (e.g. 1e-3,3e-4,1e-4): the views then decide the flame's "
         "edges. Empty: none.", default="", decls=("--tv-continuation",)),
    Flag("continuation_iterations", int, "L-BFGS-B iterations at each --tv-continuation "
         "weight (0: --iterations).", default=0, decls=("--continuation-iterations",)),
    Flag("noise", float, "The views' relative noise per pixel (σ/value), if known: the TV "
         "continuation stops once the fit is that close (discrepancy principle).", default=0.0),
    Flag("gauss_newton", int, "Gauss–Newton steps at the finest level after L-BFGS-B (each "
         "60 conjugate-gradient iterations of two renders and an adjoint; 0: none).",
         default=0, decls=("--gauss-newton",)),
    Flag("dark_fraction", float, "Hold voxels whose κ (and their neighbours') is at most this "
         "fraction of the largest at the floor, as those without κ are.", default=0.0),
    Flag("solve_absorption", bool, "Solve κ too, from the grid's κ as the first guess (emission "
         "alone hardly tells κ from T: see docs/inverse.md).", default=False,
         decls=("--solve-absorption",)),
    Flag("axisymmetric", bool, "Solve T(r, y) about the vertical axis through the box's centre "
         "(one view suffices: the Abel case).", default=False, decls=("--axisymmetric",)),
    Flag("resume", bool, "Continue from the checkpoint beside the output.", default=False,
         decls=("--resume",)),
    BACKEND.but(key=None, default="cpu", help="cpu | cuda | reference (float64)."),
    OVERWRITE.but(key=None, default=False, help="Replace existing outputs."),
)
# fmt: on


# --- scene overrides back to flags (the viewer's "copy command") ---------------------------


def _shown(value: Any, flag: Flag) -> str:
    """A scene value as ``flag``'s text, exact: floats by repr (they read back bit for bit)."""
    if flag.parse is _vector:
        return ",".join(repr(float(v)) for v in value)
    if flag.parse is _sun:
        (light,) = value
        return ",".join(repr(float(v)) for v in (*light["direction"], light["illuminance_lux"]))
    if flag.parse is _species:
        return ",".join(
            f"{k}={v!r}" if isinstance(v, float) else f"{k}={v}" for k, v in value.items()
        )
    if isinstance(value, (list, tuple)):  # LOW:HIGH, OPEN:CLOSE
        return ":".join(repr(float(v)) for v in value)
    return repr(value) if isinstance(value, float) else str(value)


def _at(table: dict, key: str) -> Any:
    for name in key.split("."):
        if not isinstance(table, dict) or name not in table:
            return None
        table = table[name]
    return table


def command_line(source: str, scene: dict, output: str = "view.png") -> str:
    """``incandescent render SOURCE -o OUTPUT`` with the flags that set the nested scene keys
    ``scene`` (the inverse of :func:`overrides`, over :data:`RENDER`'s flags), shell-quoted; a
    key no flag sets is an error naming it."""
    import shlex

    words, used = ["incandescent", "render", source, "-o", output], set()
    for flag in _flat(RENDER):
        value = None if flag.key is None else _at(scene, flag.key)
        if value is None or flag.key in used:
            continue
        used.add(flag.key)
        if flag.kind is bool:
            on, _, off = (flag.decls[0] if flag.decls else flag.flag).partition("/")
            words.append(on if value else off or "--no-" + on.removeprefix("--"))
            continue
        words += [flag.flag, _shown(value, flag)]
    missing = _leaves(scene) - used
    if missing:
        raise ValueError(f"no render flag sets {', '.join(sorted(missing))}")
    return " ".join(shlex.quote(w) for w in words)


def _leaves(table: dict, prefix: str = "") -> set[str]:
    keys = {f.key for f in _flat(RENDER) if f.key}
    out: set[str] = set()
    for name, value in table.items():
        key = prefix + name
        if isinstance(value, dict) and key not in keys:
            out |= _leaves(value, key + ".")
        else:
            out.add(key)
    return out

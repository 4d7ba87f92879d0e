"""Scene-referred XYZ (Y in cd/m²) → display-referred integer RGB, in one documented pipeline.

Stages, in order (DESIGN.md §3, "Colour output"):

1. white balance — adapt (Bradford) from the chosen white to the output space's white
   (D65 for sRGB, Rec.2020 and Display P3);
2. XYZ → linear RGB in the output space (unclipped);
3. exposure — physical camera (ISO 12232) when ``iso``, ``shutter_s`` and ``f_number`` are all
   given, else auto exposure (percentile of luminance) when ``auto_exposure``, else none; in
   every case ``exposure_ev`` is applied on top as exposure compensation;
4. gamut map (negative components removed, on the linear HDR values);
5. tone map (clip, Reinhard, filmic);
6. sRGB OETF (IEC 61966-2-1);
7. quantise to 8 or 16 bits.
"""

from __future__ import annotations

from dataclasses import dataclass
from numbers import Real

import numpy as np
from numpy.typing import ArrayLike, NDArray

from incandescent import _validate
from incandescent.colorimetry.adaptation import NAMED_WHITES_XY, adapt
from incandescent.colorimetry.rgb_spaces import RGBSpace, rgb_space, xyz_to_rgb
from incandescent.colorimetry.xyz import as_components
from incandescent.imaging.encode import BIT_DEPTHS, GAMUT_METHODS, gamut_map, quantize, srgb_oetf
from incandescent.imaging.exposure import auto_exposure_scale, camera_exposure_scale, ev_scale
from incandescent.imaging.tonemap import TONEMAPS, tonemap
from incandescent.spectra.blackbody import planckian_white

WHITE_BALANCE_NAMES: tuple[str, ...] = (*NAMED_WHITES_XY, "hottest")
_CAMERA_FIELDS = ("iso", "shutter_s", "f_number")


def _check_white_balance(value: object) -> None:
    if value is None:
        return
    if isinstance(value, str):
        _validate.choice(value, "white_balance", WHITE_BALANCE_NAMES)
    elif isinstance(value, Real) and not isinstance(value, bool):
        _validate.positive_scalar(float(value), "white_balance temperature_K")
    else:
        raise TypeError(
            f"white_balance must be None, one of {', '.join(WHITE_BALANCE_NAMES)} or a "
            f"temperature in K; got {type(value).__name__} {value!r}"
        )


def _check_camera(settings: DisplaySettings) -> None:
    given = [f for f in _CAMERA_FIELDS if getattr(settings, f) is not None]
    if given and len(given) < len(_CAMERA_FIELDS):
        missing = [f for f in _CAMERA_FIELDS if f not in given]
        raise ValueError(
            f"a physical camera needs iso, shutter_s and f_number together; got {', '.join(given)} "
            f"but not {', '.join(missing)}"
        )
    for name in given:
        _validate.positive_scalar(getattr(settings, name), name)


def _check_flag(value: object, name: str) -> None:
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be True or False; got {type(value).__name__} {value!r}")


@dataclass(frozen=True)
class DisplaySettings:
    """How to turn scene XYZ into a display image; validated on construction.

    Parameters
    ----------
    space:
        Output RGB space (registry name or :class:`RGBSpace`); the sRGB transfer function is
        applied whatever the primaries.
    white_balance:
        ``None`` (no adaptation), ``"D65"``, ``"D50"``, ``"E"``, a blackbody temperature in K
        (that blackbody becomes neutral), or ``"hottest"`` (the hottest temperature in the scene
        becomes neutral, as in Nguyen et al. 2002; pass ``hottest_K`` to :func:`to_display`).
    exposure_ev:
        Exposure compensation in stops, applied after the physical or auto exposure.
    auto_exposure, auto_percentile:
        Map this percentile of the lit pixels' luminance to 0.8 (see
        :func:`~incandescent.imaging.exposure.auto_exposure_scale`).
    iso, shutter_s, f_number:
        Physical camera (all three or none); overrides auto exposure.
    tonemap:
        ``"clip"``, ``"reinhard"`` or ``"filmic"``.
    gamut:
        ``"clip"`` or ``"desaturate"``.
    bits:
        8 or 16.

    References
    ----------
    Nguyen, D. Q., Fedkiw, R., Jensen, H. W. (2002). Physically based modeling and animation of
    fire. *ACM Transactions on Graphics* 21(3), 721–728 (§6: adapt to the hottest blackbody).
    """

    space: str | RGBSpace = "srgb"
    white_balance: str | float | None = None
    exposure_ev: float = 0.0
    auto_exposure: bool = True
    auto_percentile: float = 99.0
    iso: float | None = None
    shutter_s: float | None = None
    f_number: float | None = None
    tonemap: str = "filmic"
    gamut: str = "desaturate"
    bits: int = 8

    def __post_init__(self) -> None:
        rgb_space(self.space)
        _check_white_balance(self.white_balance)
        ev_scale(self.exposure_ev)
        _check_flag(self.auto_exposure, "auto_exposure")
        if isinstance(self.auto_percentile, bool) or not isinstance(self.auto_percentile, Real):
            raise TypeError(f"auto_percentile must be a number; got {self.auto_percentile!r}")
        if not 0.0 < float(self.auto_percentile) <= 100.0:
            raise ValueError(f"auto_percentile must be in (0, 100]; got {self.auto_percentile!r}")
        _check_camera(self)
        _validate.choice(self.tonemap, "tonemap", tuple(TONEMAPS))
        _validate.choice(self.gamut, "gamut", GAMUT_METHODS)
        if isinstance(self.bits, bool) or self.bits not in BIT_DEPTHS:
            raise ValueError(f"bits must be 8 or 16; got {self.bits!r}")

    @property
    def physical_camera(self) -> bool:
        """True when iso, shutter_s and f_number are all given."""
        return all(getattr(self, f) is not None for f in _CAMERA_FIELDS)


def _checked_xyz(xyz: ArrayLike) -> NDArray[np.float64]:
    arr = as_components(xyz, "xyz")
    bad = int((~np.isfinite(arr)).any(axis=-1).sum())
    if bad:
        total = int(np.prod(arr.shape[:-1]))
        raise ValueError(f"xyz has {bad} of {total} pixel(s) with NaN or infinite values")
    return arr


def _source_white(settings: DisplaySettings, hottest_K: float | None) -> str | NDArray | None:
    """The white to adapt from: a name, None, or a blackbody temperature resolved to its XYZ."""
    white = settings.white_balance
    if white == "hottest":
        if hottest_K is None:
            raise ValueError(
                'white_balance="hottest" needs hottest_K (the scene\'s hottest T in K)'
            )
        white = _validate.positive_scalar(hottest_K, "hottest_K")
    if white is None or isinstance(white, str):
        return white
    return planckian_white(white)


def exposure_scale(luminance: NDArray[np.float64], settings: DisplaySettings) -> float:
    """Total exposure multiplier for ``settings`` given the scene luminance (cd/m²)."""
    if settings.physical_camera:
        iso, shutter_s, f_number = (float(getattr(settings, f)) for f in _CAMERA_FIELDS)
        base = camera_exposure_scale(iso, shutter_s, f_number)
    elif settings.auto_exposure:
        base = auto_exposure_scale(luminance, settings.auto_percentile)
    else:
        base = 1.0
    return base * ev_scale(settings.exposure_ev)


def to_display(
    xyz: ArrayLike, settings: DisplaySettings | None = None, hottest_K: float | None = None
) -> NDArray[np.uint8] | NDArray[np.uint16]:
    """Scene XYZ ``(H, W, 3)`` (Y in cd/m²) → display RGB ``(H, W, 3)`` uint8 or uint16.

    See the module docstring for the stages. ``hottest_K`` (K) is required only for
    ``white_balance="hottest"``. NaN or infinite input raises ``ValueError`` naming how many
    pixels are bad; the output never contains NaN.
    """
    settings = DisplaySettings() if settings is None else settings
    space = rgb_space(settings.space)
    arr = _checked_xyz(xyz)
    target_white = np.array([*space.white_xy, 1.0 - sum(space.white_xy)]) / space.white_xy[1]
    balanced = adapt(arr, _source_white(settings, hottest_K), target_white)
    rgb = xyz_to_rgb(balanced, space) * exposure_scale(balanced[..., 1], settings)
    # Gamut-map the linear HDR values first: a per-channel tone curve applied to out-of-gamut
    # colours (negative components) can leave pixels with luminance <= 0 — black highlights.
    mapped = tonemap(gamut_map(rgb, settings.gamut, space), settings.tonemap)
    return quantize(srgb_oetf(mapped), settings.bits)


def display_pixels(image, display: DisplaySettings | None = None) -> NDArray:
    """8/16-bit display RGB of a rendered image (``HDRImage``): :func:`to_display` of its XYZ with
    ``display`` (default: the image's space), or — for display-referred images (the 2011
    paper's, whose values are already display values capped at 255) — those values (8-bit)."""
    if image.display_rgb is not None:
        return np.round(np.clip(image.display_rgb, 0.0, 255.0)).astype(np.uint8)
    display = display or DisplaySettings(space=image.space)
    return to_display(image.scene_xyz, display, hottest_K=image.metadata.get("max_temperature_K"))

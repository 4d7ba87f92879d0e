"""A camera's sensor and optics: scene radiance → electrons → raw digital numbers.

Through a lens of f-number N and transmittance τ, a scene of spectral radiance L_λ
(W·sr⁻¹·m⁻²·nm⁻¹) gives the sensor the irradiance E_λ = π τ F(λ) L_λ / (4N²) on the axis
(the camera equation for a distant object, e.g. ISO 12232's; × cos⁴θ off the axis with
``cos4``), F the filters' transmittance. A pixel of pitch p collects A = p² of it, as
λ/(hc) photons per joule, of which QE_c(λ) = ``peak_qe`` · s_c(λ) become electrons in channel c
(s_c the measured relative sensitivity). Per second of exposure:

    ė_c = ∫ L_λ k_c(λ) dλ,   k_c(λ) = π τ F(λ) A λ QE_c(λ) / (4N² h c)   [e⁻ s⁻¹ per W·sr⁻¹·m⁻²]

The renderer computes exactly this integral when its observer's three "colour matching
functions" are k_c/K_m (``observer``), for every emission model and spectral bin. An exposure
of t seconds holds ė_c·t + dark·t electrons on average; the sensor draws Poisson shot noise
and Gaussian read noise (EMVA 1288's linear model, release 4.0 §2), clips at the full well,
converts with the gain (e⁻ per DN), adds the black level and clips to the bit depth.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields

import numpy as np
from numpy.typing import NDArray

from incandescent import _validate
from incandescent.constants import K_M
from incandescent.sensor.spectra import Curves, Filter, grid_nm, response
from incandescent.spectra.cmf import register_observer

#: Planck's constant (J·s) and the speed of light (m/s), SI exact.
H_J_S, C_M_S = 6.62607015e-34, 299792458.0
#: Bayer patterns: the channel (0 R, 1 G, 2 B) of the 2×2 cell's pixels in row order.
PATTERNS = {
    "RGGB": (0, 1, 1, 2),
    "BGGR": (2, 1, 1, 0),
    "GRBG": (1, 0, 2, 1),
    "GBRG": (1, 2, 0, 1),
}


@dataclass(frozen=True, eq=False)
class Sensor:
    """A colour camera: its channels' sensitivities (``sensitivity``: a shipped name or a CSV),
    optics and electronics. Defaults: a 16 MP APS-C CMOS of the D5100's generation at base gain
    — typical published magnitudes, not this camera's measured ones (set them from an EMVA 1288
    sheet or a photon-transfer measurement for a real camera)."""

    sensitivity: str = "nikon_d5100"
    f_number: float = 8.0
    lens_transmittance: float = 0.9
    filters: tuple[Filter, ...] = ()
    exposure_s: float = 1e-4
    pixel_pitch_um: float = 4.78
    peak_qe: float = 0.4
    gain_e_per_dn: float = 2.0
    full_well_e: float = 30000.0
    read_noise_e: float = 3.0
    dark_current_e_s: float = 1.0
    black_level_dn: int = 600
    bits: int = 14
    pattern: str = "RGGB"
    cos4: bool = False
    curves: Curves = field(init=False, repr=False)

    def __post_init__(self) -> None:
        positive = ("f_number", "exposure_s", "pixel_pitch_um", "peak_qe", "gain_e_per_dn",
                    "full_well_e")  # fmt: skip
        for name in positive:
            object.__setattr__(self, name, _validate.positive_scalar(getattr(self, name), name))
        for name in ("lens_transmittance", "read_noise_e", "dark_current_e_s"):
            value = _validate.finite_scalar(getattr(self, name), name)
            if value < 0:
                raise ValueError(f"sensor {name} must be >= 0; got {getattr(self, name)!r}")
        if not 0 < self.lens_transmittance <= 1 or not 0 < self.peak_qe <= 1:
            raise ValueError(f"sensor lens_transmittance and peak_qe must be in (0, 1]; got "
                             f"{self.lens_transmittance!r}, {self.peak_qe!r}")  # fmt: skip
        _check_levels(self.bits, self.black_level_dn)
        _validate.choice(self.pattern, "Bayer pattern", tuple(PATTERNS))
        object.__setattr__(self, "filters", tuple(self.filters))
        object.__setattr__(self, "curves", response(self.sensitivity))

    @property
    def white_level_dn(self) -> int:
        """The largest DN: 2^bits − 1."""
        return (1 << self.bits) - 1

    def weights(self) -> NDArray[np.float64]:
        """k_c(λ) on the CIE grid, (471, 3): electrons per second per (W·sr⁻¹·m⁻²·nm⁻¹) per nm
        of scene radiance, on the axis."""
        lam = grid_nm()
        optics = np.pi * self.lens_transmittance / (4.0 * self.f_number**2)
        area_m2 = (self.pixel_pitch_um * 1e-6) ** 2
        photons_per_j = lam * 1e-9 / (H_J_S * C_M_S)
        through = np.ones_like(lam)
        for f in self.filters:
            through = through * f.transmittance()
        qe = self.peak_qe * self.curves.on_grid()
        return (optics * area_m2 * photons_per_j * through)[:, None] * qe

    def observer(self) -> str:
        """The renderer's observer whose "XYZ" is ė_c in e⁻/s (k_c / K_m, registered)."""
        return register_observer("sensor", self.weights() / K_M)

    def mean_electrons(self, rate_e_s: NDArray, cos4: NDArray | None = None) -> NDArray:
        """Mean electrons per pixel and channel in the exposure: (ė·cos⁴θ + dark)·t."""
        rate = np.asarray(rate_e_s, dtype=np.float64)
        if cos4 is not None and self.cos4:
            rate = rate * cos4[..., None]
        return (rate + self.dark_current_e_s) * self.exposure_s

    def channel_map(self, height: int, width: int) -> NDArray[np.int64]:
        """The channel (0 R, 1 G, 2 B) of every pixel of the mosaic, (H, W)."""
        cell = np.asarray(PATTERNS[self.pattern]).reshape(2, 2)
        return np.tile(cell, (height // 2, width // 2))

    def mosaic(self, electrons: NDArray, seed: int | None = 0, noise: bool = True) -> NDArray:
        """Raw DN (H, W) uint16 from mean electrons (H, W, 3): each pixel its channel's,
        Poisson shot noise and Gaussian read noise (``seed``; ``noise`` False: the means,
        rounded), clipped at the full well, / gain, + black level, clipped to the bit depth."""
        height, width, _ = electrons.shape
        if height % 2 or width % 2:
            raise ValueError(f"a Bayer mosaic needs an even width and height; got {width}×{height}")
        channel = self.channel_map(height, width)
        mean = np.take_along_axis(electrons, channel[..., None], axis=2)[..., 0]
        if noise:
            rng = np.random.default_rng(seed)
            mean = rng.poisson(mean).astype(np.float64)
            mean = mean + rng.normal(0.0, self.read_noise_e, mean.shape)
        collected = np.clip(mean, 0.0, self.full_well_e)
        dn = np.floor(collected / self.gain_e_per_dn + 0.5) + self.black_level_dn
        return np.clip(dn, 0, self.white_level_dn).astype(np.uint16)

    def check_exposure(self, electrons: NDArray) -> None:
        """One line when the exposure saturates every pixel (its dimmest channel's median at the
        full well), naming an exposure that would not."""
        signal = np.median(electrons.reshape(-1, 3), axis=0)
        if signal.min() >= self.full_well_e:
            better = self.exposure_s * 0.5 * self.full_well_e / float(signal.max())
            raise ValueError(
                f"exposure {self.exposure_s:g} s saturates every pixel (median "
                f"{signal.min():.3g} e⁻ ≥ full well {self.full_well_e:g} e⁻); try exposure "
                f"{better:.3g} s"
            )

    def parameters(self) -> dict[str, object]:
        """Every parameter, for a raw file's sidecar."""
        out: dict[str, object] = {}
        for f in fields(self):
            if f.name == "curves":
                continue
            value = getattr(self, f.name)
            out[f.name] = [vars(x) for x in value] if f.name == "filters" else value
        return out | {"white_level_dn": self.white_level_dn}


def _check_levels(bits, black) -> None:
    """A bit depth in 8..16 and a black level below the white level."""
    integer = isinstance(bits, (int, np.integer)) and not isinstance(bits, bool)
    if not integer or not 8 <= bits <= 16:
        raise ValueError(f"sensor bits must be an integer in 8..16; got {bits!r}")
    if isinstance(black, bool) or not isinstance(black, (int, np.integer)):
        raise ValueError(f"sensor black_level_dn must be an integer; got {black!r}")
    if not 0 <= black < (1 << bits) - 1:
        raise ValueError(f"sensor black_level_dn must be in 0..{(1 << bits) - 2}; got {black}")

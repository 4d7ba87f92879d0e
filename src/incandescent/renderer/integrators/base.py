"""The integrator interface: one way of transporting light along a camera ray, on the host, in
the Dr.Jit kernel and in the float64 reference (``docs/design/DESIGN.md`` §3).

The backends own what every transport shares — camera rays, the step lattice, empty-space
skipping, sampling κ and T at a segment's midpoint, early termination, chunks — and hand each
segment to the integrator (Mitsuba 3's split between its ``Integrator`` plugins and the render
loop; pbrt-v4's ``VolPathIntegrator`` vs the film/sampler). An integrator is a frozen value
holding its parameters; per render it builds

* a :class:`Traced` program (Dr.Jit, :meth:`Integrator.traced`): which samples interact, the
  per-segment update of the running state (transmittance, radiance), its start and its end;
* a :class:`Reference` program (NumPy float64, :meth:`Integrator.reference`): the same, exact.

Adding an integrator is one subclass plus a registry line
(:func:`incandescent.renderer.integrators.register`); ``tests/renderer/test_integrators.py``
shows a toy one on the reference and on Dr.Jit.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from incandescent.emission.base import Bands
from incandescent.emission.blackbody import blackbody_lut
from incandescent.renderer.backends.common import Segment


class Traced:
    """An integrator's traced program for one render (``kernel``: the march's ``_Kernel``, whose
    helpers — ``trilinear``, ``lut_position``, ``lookup``, ``table``, ``grid`` — sample the
    medium and the tables). The default is one grey transmittance."""

    def __init__(self, kernel) -> None:
        self.kernel = kernel

    def transmittance0(self):
        """The loop's initial transmittance state."""
        return self.kernel.m.Float(1.0)

    def alive(self, tr):
        """Traced: the transmittance early termination compares with ``min_transmittance``."""
        return tr

    def transmittance_out(self, tr):
        """Traced: the per-ray transmittance reported in the image."""
        return tr

    def interacts(self, kappa, temp, sampled) -> tuple[Any, Any]:
        """Traced: (where a sample runs :meth:`step`, where it emits — the depth channel)."""
        raise NotImplementedError

    def step(self, tr, L, kappa, temp, c, ds_m, sampled) -> tuple[Any, Any]:
        """Traced: (Tr, L) after one segment of ``ds_m`` metres at trilinear corners ``c``."""
        raise NotImplementedError


class Reference:
    """An integrator's float64 program for one render (``inputs``: the ``MarchInputs``). The
    default is one grey transmittance per ray."""

    def __init__(self, inputs) -> None:
        self.inputs = inputs

    def transmittance0(self, n: int) -> NDArray[np.float64]:
        return np.ones(n)

    def alive(self, tr_rows: NDArray) -> NDArray:
        """The transmittance of rows ``tr_rows`` compared with ``min_transmittance``."""
        return tr_rows

    def transmittance_out(self, tr: NDArray) -> NDArray:
        return tr

    def step(self, segment: Segment, xyz: NDArray, tr: NDArray) -> NDArray[np.bool_]:
        """Add one segment's light to ``xyz`` and update ``tr`` in place (rows ``segment.r``);
        returns the mask of rays whose sample emits."""
        raise NotImplementedError


class Integrator(ABC):
    """A light-transport method. Subclasses set ``name`` and implement the host methods,
    :meth:`traced` and :meth:`reference`."""

    name: ClassVar[str]
    #: the image is display-referred RGB (``HDRImage.display_rgb``), not absolute XYZ
    display_referred: ClassVar[bool] = False

    # --- host -------------------------------------------------------------------------------
    @abstractmethod
    def models(self, volume) -> tuple:
        """The emission models (``incandescent.emission``) this integrator uses for ``volume``."""

    def first_table(self, models: tuple):
        """The table whose 1/T spacing and T_min every table of the render shares: the first
        model's first table, or the blackbody table (``spectra.lut``) without models."""
        return models[0].tables[0] if models else blackbody_lut("cie1931_2", "codata2018")

    def bands(self, models: tuple) -> Bands:
        """The wavelength bands of transport (default: one grey band)."""
        return Bands()

    def occupancy(self, models: tuple) -> tuple[str, Callable | None]:
        """(cache key, volume → grid > 0 where a sample may interact) for the macrocells;
        ("absorption", None): where κ > 0 alone."""
        return "absorption", None

    def sparse_problem(self, models: tuple) -> str | None:
        """Why the sparse (T and κ only) layout cannot carry this integrator, or None."""
        return None

    def film(self, values: NDArray) -> tuple[NDArray | None, NDArray | None]:
        """(XYZ, display RGB) of the image from the per-pixel sums, float32; one is None."""
        return values.astype(np.float32), None

    def metadata(self) -> dict[str, object]:
        """What the image's metadata records of this integrator."""
        return {"integrator": self.name}

    def check_models(self, models: tuple) -> tuple:
        """``models`` given to ``render(models=…)``, checked for this integrator."""
        return tuple(models)

    # --- kernel and reference ---------------------------------------------------------------
    @abstractmethod
    def traced(self, kernel) -> Traced:
        """This integrator's traced program for one render."""

    @abstractmethod
    def reference(self, inputs) -> Reference:
        """This integrator's float64 program for one render."""

"""Integrators: one class per way of transporting light along a ray (``integrators.base`` has
the interface), chosen by name in a scene file's ``[integrator]`` section as Mitsuba 3 chooses its
plugins from a dict (``type`` plus the class's parameters):

* ``emission_absorption`` (:class:`EmissionAbsorption`): absolute radiance, grey or in spectral
  bins — the default;
* ``paper2011`` (:class:`Paper2011`): the 2011 paper's display-referred sums;
* ``single_scattering`` (:class:`SingleScattering`): emission–absorption plus lights scattered
  once by the volume's σ_s;
* ``multiple_scattering`` (:class:`MultipleScattering`): every order up to ``max_bounces``, by
  Monte Carlo paths.

A new integrator is a subclass of :class:`Integrator` and one :func:`register` call; no backend
changes.
"""

from __future__ import annotations

from collections.abc import Mapping

from incandescent import _validate
from incandescent.renderer.integrators import spectral_scattering  # noqa: F401  (registers)
from incandescent.renderer.integrators.base import Integrator, Reference, Segment, Traced
from incandescent.renderer.integrators.emission_absorption import EmissionAbsorption
from incandescent.renderer.integrators.multiple_scattering import MultipleScattering
from incandescent.renderer.integrators.paper2011 import Paper2011
from incandescent.renderer.integrators.single_scattering import SingleScattering

__all__ = [
    "INTEGRATORS",
    "EmissionAbsorption",
    "Integrator",
    "MultipleScattering",
    "Paper2011",
    "Reference",
    "Segment",
    "SingleScattering",
    "Traced",
    "integrator_from_dict",
    "register",
]

#: Integrator classes by the name a scene file's ``[integrator] type`` gives.
INTEGRATORS: dict[str, type[Integrator]] = {
    EmissionAbsorption.name: EmissionAbsorption,
    Paper2011.name: Paper2011,
    SingleScattering.name: SingleScattering,
    MultipleScattering.name: MultipleScattering,
}


def register(cls: type[Integrator]) -> type[Integrator]:
    """Make ``cls`` available by its ``name`` (usable as a class decorator)."""
    if not (isinstance(cls, type) and issubclass(cls, Integrator)):
        raise TypeError(f"an integrator must subclass incandescent Integrator; got {cls!r}")
    INTEGRATORS[cls.name] = cls
    return cls


def integrator_from_dict(spec: Mapping[str, object], **context) -> Integrator:
    """The integrator ``{"type": NAME, **parameters}`` describes; ``context`` (e.g. ``emission``)
    is passed to the classes whose constructors take it."""
    spec = dict(spec)
    name = str(spec.pop("type", EmissionAbsorption.name))
    cls = INTEGRATORS[_validate.choice(name, "integrator", tuple(INTEGRATORS))]
    fields = getattr(cls, "__dataclass_fields__", {})
    for key, value in context.items():
        if key in fields and key not in spec:
            spec[key] = value
    unknown = sorted(set(spec) - set(fields))
    if unknown:
        raise ValueError(
            f"integrator {name!r} has no parameter {', '.join(map(repr, unknown))}; it takes: "
            f"{', '.join(k for k in fields if k not in context) or 'none'}"
        )
    return cls(**spec)

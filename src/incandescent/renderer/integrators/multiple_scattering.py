"""Multiple scattering: every order of scattering up to ``max_bounces``, by Monte Carlo paths
(``monte_carlo``) that start at each scattering sample of the camera ray.

The camera ray is marched as in single scattering — emission, extinction by σ_t = κ + σ_s and
the first order of every light exactly or by next-event estimation — and each of its
scattering samples adds, averaged over ``spp`` paths, the light that reaches it after one or
more further scatterings: the radiative transfer equation's in-scattering term
σ_s ∫ p L dω (Chandrasekhar 1960, §1) with L itself scattered light, solved by its Neumann
series as a path tracer does (Kajiya 1986; pbrt-v4's ``VolPathIntegrator``, whose ``maxdepth``
counts the same scattering events: ``max_bounces`` = N gives orders 1 … N of every light).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from incandescent.renderer.integrators.single_scattering import SingleScattering

#: Most orders of scattering a render may ask for.
MAX_BOUNCES = 1024


@dataclass(frozen=True)
class MultipleScattering(SingleScattering):
    """Emission–absorption plus orders 1 … ``max_bounces`` of the scattering of ``lights``
    (grey, or spectral bins); ``spp`` paths per scattering sample of a camera ray."""

    max_bounces: int = 64  # type: ignore[misc]

    name = "multiple_scattering"

    def __post_init__(self) -> None:
        super().__post_init__()
        bounces = self.max_bounces
        integer = isinstance(bounces, (int, np.integer)) and not isinstance(bounces, bool)
        if not integer or not 2 <= bounces <= MAX_BOUNCES:
            raise ValueError(
                f"max_bounces must be an integer in 2..{MAX_BOUNCES} for multiple_scattering "
                f"(1 is single_scattering); got {bounces!r}"
            )
        object.__setattr__(self, "max_bounces", int(bounces))

    def metadata(self) -> dict[str, object]:
        return {**super().metadata(), "max_bounces": self.max_bounces}

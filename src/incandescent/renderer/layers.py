"""Compositing layers of a scattering render: what the gas emits, what it scatters once, what it
scatters more than once, and what each light gives — so artists relight in comp and scientists
separate emitted from scattered light.

Each layer is a difference of renders of the same frame with the same samples: the camera rays,
their step lattice and the hashed Monte Carlo samples (``integrators.monte_carlo``) do not
depend on which lights are present or how many orders are kept, so

* ``emission`` = the render with no lights (emission, seen through σ_t = κ + σ_s);
* ``scatter.direct`` = single scattering − emission (order 1 of every light);
* ``scatter.indirect`` = the beauty − single scattering (orders 2 … ``max_bounces``);
* ``light.N`` = the render with light N alone − emission (all its orders),

and emission + direct + indirect is the beauty to float32 rounding. The per-light layers sum to
the scattered light exactly without the fire's own light, and to Monte Carlo noise with it (its
cells guide the paths of every light). Cost: 3 + (number of lights, if more than one) renders.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from incandescent.renderer.film import HDRImage
from incandescent.renderer.integrators import Integrator, SingleScattering


def _single(integrator: SingleScattering, lights) -> SingleScattering:
    """``integrator``'s single-scattering counterpart with ``lights`` (same spp, shadows, step)."""
    fields = {"spectral_bins", "emission", "shadows", "spp", "path_step_voxels", "in_scatter",
              "cache_pairs", "cache_voxels"}  # fmt: skip
    return SingleScattering(lights=tuple(lights), **{k: getattr(integrator, k) for k in fields})


def with_layers(render, integrator: Integrator) -> HDRImage:
    """The beauty ``render(integrator)`` with its layers (``render``: integrator → HDRImage for
    one frame, camera and settings)."""
    if not isinstance(integrator, SingleScattering):
        raise ValueError(
            f"layers split scattered light: they need a single_scattering or multiple_scattering "
            f"integrator; got {integrator.name!r}"
        )
    beauty = render(integrator)
    emission = render(_single(integrator, ())).scene_xyz
    single = beauty if type(integrator) is SingleScattering else None
    if single is None:
        single = render(_single(integrator, integrator.lights))
    layers = {
        "emission": emission,
        "scatter.direct": single.scene_xyz - emission,
        "scatter.indirect": beauty.scene_xyz - single.scene_xyz,
    }
    if len(integrator.lights) > 1:
        for index, light in enumerate(integrator.lights):
            alone = render(replace(integrator, lights=(light,)))
            layers[f"light.{index}"] = alone.scene_xyz - emission
    layers = {name: np.asarray(xyz, dtype=np.float32) for name, xyz in layers.items()}
    names = {f"light.{i}": repr(light) for i, light in enumerate(integrator.lights)}
    metadata = {**beauty.metadata, "layers": ", ".join(layers), **names}
    return replace(beauty, layers=layers, metadata=metadata)

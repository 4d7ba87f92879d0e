"""Physical constants, each with its provenance.

SI values are exact since the 2019 redefinition (CODATA 2018). Planck's law is written with the
two radiation constants ``c1L = 2 h c**2`` (for spectral *radiance*, W·m²·sr⁻¹) and
``c2 = h c / k_B`` (m·K). Three constant sets are offered, see :data:`PLANCK_CONSTANT_SETS`.
"""

from __future__ import annotations

from dataclasses import dataclass

#: Planck constant, J·s (exact, SI 2019).
H_PLANCK = 6.62607015e-34
#: Speed of light in vacuum, m/s (exact).
C_LIGHT = 299_792_458.0
#: Boltzmann constant, J/K (exact, SI 2019).
K_BOLTZMANN = 1.380649e-23
#: Boltzmann constant in eV/K (exact: k_B / e).
K_BOLTZMANN_EV = 8.617333262e-5
#: Stefan–Boltzmann constant, W·m⁻²·K⁻⁴ (CODATA 2018, derived from exact constants).
SIGMA_SB = 5.670374419e-8
#: Wien displacement constant b in λ_max = b / T, m·K (CODATA 2018).
WIEN_B = 2.897771955e-3
#: Maximum luminous efficacy of photopic vision, lm/W (CIE; defines the candela at 555 nm).
K_M = 683.0


@dataclass(frozen=True)
class PlanckConstants:
    """The two radiation constants of Planck's law.

    Attributes
    ----------
    name:
        Key in :data:`PLANCK_CONSTANT_SETS`.
    c1:
        First radiation constant for spectral *exitance*, ``2 π h c²`` in W·m² (the paper's c1).
    c2:
        Second radiation constant ``h c / k_B`` in m·K.
    """

    name: str
    c1: float
    c2: float

    @property
    def c1L(self) -> float:  # noqa: N802 - textbook symbol
        """First radiation constant for spectral *radiance*, ``c1 / π = 2 h c²`` in W·m²·sr⁻¹."""
        return self.c1 / 3.141592653589793


#: CODATA 2018 (default): c1 = 2πhc², c2 = hc/k from the exact SI constants.
CODATA_2018 = PlanckConstants(
    "codata2018",
    c1=2.0 * 3.141592653589793 * H_PLANCK * C_LIGHT**2,
    c2=H_PLANCK * C_LIGHT / K_BOLTZMANN,
)
#: CIE 015:2018 / ITS-90 second radiation constant c2 = 1.4388e-2 m·K (what colour-science uses);
#: c1 from CODATA. Its c2 is 1.6e-5 (relative) above CODATA 2018's, which lowers B_λ by
#: about x·1.6e-5 at x = c2/(λT), e.g. 2e-4 at 555 nm and 2000 K.
CIE_ITS90 = PlanckConstants("cie", c1=CODATA_2018.c1, c2=1.4388e-2)
#: The 2011 paper's constants: c1 = 3.74183e-16 W·m², c2 = 1.4388e-2 m·K.
PAPER_2011 = PlanckConstants("paper", c1=3.74183e-16, c2=1.4388e-2)

PLANCK_CONSTANT_SETS: dict[str, PlanckConstants] = {
    c.name: c for c in (CODATA_2018, CIE_ITS90, PAPER_2011)
}


def planck_constants(name: str | PlanckConstants) -> PlanckConstants:
    """Look up a constant set by name (``codata2018``, ``cie``, ``paper``)."""
    if isinstance(name, PlanckConstants):
        return name
    try:
        return PLANCK_CONSTANT_SETS[name]
    except KeyError:
        valid = ", ".join(PLANCK_CONSTANT_SETS)
        raise ValueError(
            f"unknown Planck constant set {name!r}; expected one of: {valid}"
        ) from None

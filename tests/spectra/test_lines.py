"""Species line tables: data, Boltzmann scaling, line deposit, normalisation, LUT, validation."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from incandescent.colorimetry.xyz import xyz_to_xy
from incandescent.constants import K_BOLTZMANN_EV
from incandescent.spectra.blackbody import blackbody_xyz
from incandescent.spectra.cmf import cmfs
from incandescent.spectra.lines import (
    T_REF_K,
    build_species_lut,
    line_profiles,
    load_lines,
    species_names,
    species_spectrum,
    species_xyz,
)

HEADER = "species,wavelength_nm,relative_intensity,upper_energy_eV,width_nm,source\n"


@pytest.fixture(scope="module")
def table():
    return load_lines()


def _write(tmp_path: Path, body: str, name: str = "user.csv") -> Path:
    path = tmp_path / name
    path.write_text(body, encoding="utf-8")
    return path


def _cmf_xy_at(wavelength_nm: float) -> np.ndarray:
    cmf = cmfs()
    bar = np.array([np.interp(wavelength_nm, cmf.wavelength_nm, c) for c in cmf.xyz_bar.T])
    return bar[:2] / bar.sum()


# --------------------------------------------------------------------------- shipped data

REQUIRED = {
    "Na": [(588.995, 2.104), (589.592, 2.102)],
    "Li": [(670.776, 1.848), (670.791, 1.848)],
    "K": [(766.490, 1.617), (769.896, 1.610), (404.414, 3.065), (404.721, 3.063)],
    "Sr": [(460.733, 2.690)],
    "Ba": [(553.548, 2.239)],
    "Ca": [(422.673, 2.933)],
    "Cu": [(510.554, 3.817), (515.324, 6.191), (521.820, 6.192)],
    "CH": [(431.4, 2.87)],
    "C2": [(516.5, 2.48)],
}


def test_shipped_table_has_required_species_lines_and_sources(table):
    assert set(REQUIRED) <= set(species_names(table))
    for species, lines in REQUIRED.items():
        rows = table.rows_of(species)
        for wavelength, energy in lines:
            hit = rows[np.isclose(table.wavelength_nm[rows], wavelength, atol=1e-6)]
            assert hit.size == 1, (species, wavelength)
            assert table.upper_energy_eV[hit[0]] == pytest.approx(energy, abs=1e-9)
    assert all(s for s in table.source)
    molecular = table.width_nm > 0
    assert all("approx" in s for s, m in zip(table.source, molecular, strict=True) if m)


def test_molecular_bands_present(table):
    def band_centres(species):
        rows = table.rows_of(species)
        return table.wavelength_nm[rows][table.width_nm[rows] > 0]

    assert any(600 <= w <= 612 for w in band_centres("Sr"))  # SrOH orange
    assert sum(640 <= w <= 690 for w in band_centres("Sr")) >= 3  # SrOH/SrCl red
    assert sum(505 <= w <= 533 for w in band_centres("Ba")) >= 3  # BaCl green
    assert {554.0, 622.0} <= set(band_centres("Ca"))  # CaOH
    assert sum(428 <= w <= 452 for w in band_centres("Cu")) >= 3  # CuCl blue


# --------------------------------------------------------------------------- physics


def test_sodium_voxel_has_d_line_chromaticity(table):
    xy = xyz_to_xy(species_xyz(table, "Na", [1000.0, 2000.0, 5000.0]))
    # the D lines' exact chromaticity: their powers times the CMFs interpolated at 588.995/589.592
    rows = table.rows_of("Na")
    cmf = cmfs()
    bars = np.array(
        [
            [np.interp(w, cmf.wavelength_nm, c) for c in cmf.xyz_bar.T]
            for w in (table.wavelength_nm[rows])
        ]
    )
    inv = 1.0 / np.array([1000.0, 2000.0, 5000.0])[:, None] - 1.0 / T_REF_K
    power = table.relative_intensity[rows] * np.exp(
        -table.upper_energy_eV[rows] / K_BOLTZMANN_EV * inv
    )
    np.testing.assert_allclose(xy, xyz_to_xy(power @ bars), rtol=1e-10)
    # ≈ (0.57, 0.43): the CMF at the D-line centroid 589.19 nm (D2:D1 = 2:1); 589.0 nm is 1.2e-3 off
    np.testing.assert_allclose(xy, np.broadcast_to(_cmf_xy_at(589.19), xy.shape), atol=1e-4)
    np.testing.assert_allclose(xy, np.broadcast_to(_cmf_xy_at(589.0), xy.shape), atol=1.5e-3)
    np.testing.assert_allclose(xy[1], [0.5704, 0.4290], atol=1e-4)


def test_single_line_chromaticity_is_interpolated_cmf(tmp_path):
    path = _write(tmp_path, HEADER + "X,517.3,1,2.4,0,test\n")
    xy = xyz_to_xy(species_xyz(load_lines(path), "X", 2000.0))
    np.testing.assert_allclose(xy, _cmf_xy_at(517.3), rtol=1e-12)


@pytest.mark.parametrize("species", ["Li", "CH", "C2"])  # one upper-level energy each
def test_emission_follows_boltzmann_factor(table, species):
    energy = table.upper_energy_eV[table.rows_of(species)][0]
    temps = np.array([800.0, 1500.0, 2500.0, 6000.0])
    total = species_xyz(table, species, temps).sum(axis=-1)
    expected = np.exp(-energy / K_BOLTZMANN_EV * (1.0 / temps - 1.0 / temps[0]))
    np.testing.assert_allclose(total / total[0], expected, rtol=1e-12)


def test_multi_line_species_is_sum_of_boltzmann_terms(tmp_path):
    path = _write(tmp_path, HEADER + "X,450,1,3.0,0,a\nX,650,2,1.5,0,b\n")
    tab = load_lines(path)
    temps = np.array([1200.0, 3000.0])
    spec = species_spectrum(tab, "X", temps, cmfs().wavelength_nm)
    # the 650 nm line sits on one sample: its power ratio is exactly the Boltzmann ratio
    ratio = spec[1, 650 - 360] / spec[0, 650 - 360]
    assert ratio == pytest.approx(math.exp(-1.5 / K_BOLTZMANN_EV * (1 / 3000 - 1 / 1200)), 1e-12)


def test_absolute_scale_matches_blackbody_luminance_at_reference(table):
    y_bb = blackbody_xyz(T_REF_K)[1]
    for species in species_names(table):
        assert species_xyz(table, species, T_REF_K)[1] == pytest.approx(y_bb, rel=1e-12)


def test_spectrum_integrates_to_xyz_on_cmf_grid(table):
    cmf = cmfs()
    temps = np.array([900.0, 2200.0])
    for species in ("Na", "Sr", "Cu"):
        spec = species_spectrum(table, species, temps, cmf.wavelength_nm)
        xyz = 683.0 * cmf.step_nm * spec @ cmf.xyz_bar
        np.testing.assert_allclose(xyz, species_xyz(table, species, temps), rtol=1e-12)


# --------------------------------------------------------------------------- deposit


@pytest.mark.parametrize("step", [0.5, 1.0, 5.0])
@pytest.mark.parametrize("fwhm", [0.0, 0.3, 1.0, 4.0, 20.0])
def test_line_deposit_preserves_integral(step, fwhm):
    grid = np.arange(360.0, 830.0 + step / 2, step)
    centres = np.random.default_rng(5).uniform(420.0, 760.0, 50)
    prof = line_profiles(grid, centres, np.full(50, fwhm))
    np.testing.assert_allclose(prof.sum(axis=1) * step, 1.0, rtol=1e-12)
    assert (prof >= 0).all()


def test_zero_width_deposit_is_linear_interpolation():
    grid = np.arange(500.0, 510.0)
    prof = line_profiles(grid, [503.25, 506.0], [0.0, 0.0])
    expected = np.zeros((2, 10))
    expected[0, 3], expected[0, 4], expected[1, 6] = 0.75, 0.25, 1.0
    np.testing.assert_allclose(prof, expected, atol=1e-15)


def test_gaussian_deposit_limits():
    grid = np.arange(400.0, 700.0)
    narrow = line_profiles(grid, [551.37], [1e-7])
    np.testing.assert_allclose(narrow, line_profiles(grid, [551.37], [0.0]), atol=1e-6)
    fwhm = 30.0
    sigma = fwhm / (2 * math.sqrt(2 * math.log(2)))
    wide = line_profiles(grid, [551.37], [fwhm])[0]
    pdf = np.exp(-0.5 * ((grid - 551.37) / sigma) ** 2) / (sigma * math.sqrt(2 * math.pi))
    np.testing.assert_allclose(wide, pdf, atol=1e-3 * pdf.max())  # hat smoothing: +h²/6 variance


def test_spectrum_grid_must_be_uniform(table):
    with pytest.raises(ValueError, match="uniformly spaced"):
        species_spectrum(table, "Na", 2000.0, [500.0, 501.0, 503.0])


# --------------------------------------------------------------------------- LUT


def test_species_lut_interpolation_error(table):
    for species in species_names(table):
        lut = build_species_lut(table, species, 20_000.0)
        w = np.linspace(1.0 / lut.t_max_K, 1.0 / lut.t_min_K, lut.size)
        t_mid = 1.0 / (0.5 * (w[:-1] + w[1:]))
        exact = species_xyz(table, species, t_mid)
        got = lut.lookup(t_mid)
        live = exact > 1e-30 * exact.max(axis=0)
        rel = np.abs(got - exact)[live] / exact[live]
        assert rel.max() <= 1e-4, (species, rel.max())


# --------------------------------------------------------------------------- chromaticities


def test_species_chromaticities_are_plausible(table):
    xy = {s: xyz_to_xy(species_xyz(table, s, 2000.0)) for s in species_names(table)}
    assert xy["Li"][0] > 0.65  # 670.8 nm: deep red
    assert xy["Sr"][0] > 0.6  # SrOH/SrCl red
    assert xy["K"][0] > 0.6  # 766/770 nm dominate in LTE at 2000 K
    assert xy["Ca"][0] > 0.45 and xy["Ca"][1] > 0.4  # CaOH orange
    assert xy["Ba"][1] > 0.6  # BaCl green
    assert xy["Cu"][0] < 0.25 and xy["Cu"][1] < 0.3  # CuCl blue
    assert xy["CH"][0] < 0.2 and xy["CH"][1] < 0.05  # 431 nm violet-blue
    assert xy["C2"][0] < 0.3 and xy["C2"][1] > 0.35  # Swan bands blue-green
    # hotter potassium: the violet 404 nm lines (E_u 3.06 eV) gain on the red ones (1.61 eV)
    k_hot = xyz_to_xy(species_xyz(table, "K", 3500.0))
    assert k_hot[0] < xy["K"][0] - 0.1


# --------------------------------------------------------------------------- user tables


def test_user_toml_table_loads(tmp_path):
    body = """
[[lines]]
species = "Rb"
wavelength_nm = 780.027
relative_intensity = 100
upper_energy_eV = 1.589
source = "NIST ASD"

[[lines]]
species = "Rb"
wavelength_nm = 794.760
relative_intensity = 50
upper_energy_eV = 1.560
width_nm = 0.5
"""
    tab = load_lines(_write(tmp_path, body, "rb.toml"))
    assert species_names(tab) == ("Rb",)
    assert tab.width_nm.tolist() == [0.0, 0.5]
    assert tab.source == ("NIST ASD", "")
    assert species_xyz(tab, "Rb", T_REF_K)[1] == pytest.approx(blackbody_xyz(T_REF_K)[1])


BAD_CSV = [
    ("Na,1200,1,2,0,s\n", r"bad.csv line 2 \(species 'Na'\), column 'wavelength_nm': .*300–900"),
    ("Na,589,-1,2,0,s\n", r"line 2 .*column 'relative_intensity': must be >= 0; got -1"),
    ("Na,589,1,-2,0,s\n", r"line 2 .*column 'upper_energy_eV': must be >= 0"),
    ("Na,589,1,2,-0.5,s\n", r"line 2 .*column 'width_nm': must be >= 0"),
    ("Na,589,1,99,0,s\n", r"column 'upper_energy_eV': must be <= 15 eV"),
    ("Na,abc,1,2,0,s\n", r"column 'wavelength_nm': must be a number; got 'abc'"),
    ("Na,589,nan,2,0,s\n", r"column 'relative_intensity': must be finite"),
    ("Na,589,,2,0,s\n", r"column 'relative_intensity': missing value"),
    ("Na,589,1,2,0\n", r"line 2: 5 cells; the header has 6 columns"),
    (",589,1,2,0,s\n", r"column 'species': must be a non-empty name"),
    (
        "Na,589,1,2,0,s\nNa,589.0,2,2,0,t\n",
        r"bad.csv line 3: duplicate row .*'Na' at 589 nm \(first given at line 2\)",
    ),
    ("", r"bad.csv: the table has no rows"),
]


@pytest.mark.parametrize(("rows", "message"), BAD_CSV)
def test_bad_csv_rows_are_reported(tmp_path, rows, message):
    with pytest.raises(ValueError, match=message):
        load_lines(_write(tmp_path, HEADER + rows, "bad.csv"))


@pytest.mark.parametrize(
    ("header", "message"),
    [
        (
            "species,wavelength_nm,upper_energy_eV\n",
            r"missing column\(s\) \['relative_intensity'\]",
        ),
        (HEADER.strip() + ",colour\n", r"unknown column\(s\) \['colour'\]"),
        ("# only a comment\n", r"no header row"),
    ],
)
def test_bad_csv_headers_are_reported(tmp_path, header, message):
    with pytest.raises(ValueError, match=message):
        load_lines(_write(tmp_path, header, "bad.csv"))


def test_bad_toml_and_formats(tmp_path):
    with pytest.raises(ValueError, match=r"unknown top-level key\(s\) \['line'\]"):
        load_lines(_write(tmp_path, '[[line]]\nspecies = "Na"\n', "t.toml"))
    with pytest.raises(ValueError, match=r"t.toml lines\[0\]: missing column"):
        load_lines(_write(tmp_path, '[[lines]]\nspecies = "Na"\n', "t.toml"))
    body = '[[lines]]\nspecies = "Na"\nwavelength_nm = true\nrelative_intensity = 1\n'
    with pytest.raises(ValueError, match=r"lines\[0\] \(species 'Na'\), column 'wavelength_nm'"):
        load_lines(_write(tmp_path, body + "upper_energy_eV = 2\n", "t.toml"))
    with pytest.raises(ValueError, match=r"not valid TOML"):
        load_lines(_write(tmp_path, "[[lines]\n", "t.toml"))
    with pytest.raises(ValueError, match=r"expected .csv or .toml"):
        load_lines(_write(tmp_path, "", "t.json"))


def test_unknown_species_and_invisible_species(table, tmp_path):
    with pytest.raises(ValueError, match=r"unknown species 'Xe'; expected one of: Na, Li"):
        species_xyz(table, "Xe", 2000.0)
    invisible = load_lines(_write(tmp_path, HEADER + "IR,880,1,1.4,0,s\n"))
    with pytest.raises(ValueError, match=r"'IR' .* has no visible emission"):
        species_xyz(invisible, "IR", 2000.0)
    with pytest.raises(ValueError, match=r"temperature_K must be > 0 K"):
        species_xyz(table, "Na", [-5.0])

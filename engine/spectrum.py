"""Colour science the core needs in more than one place: the CIE 1931 colour-matching
functions (the Wavelength node, shading.wavelength) and, from them, the sensitivity of RGB
to the interference of a thin film (fresnel.thin_film_dielectric)."""

from __future__ import annotations

import numpy as np

# The CIE 1931 colour-matching functions (x, y, z) every 5 nm from 380 to 780 nm, as
# Cycles tabulates them (kernel/tables.h cie_color_match).
CIE_COLOUR_MATCH = np.array([
    (0.0014, 0.0000, 0.0065), (0.0022, 0.0001, 0.0105), (0.0042, 0.0001, 0.0201),
    (0.0076, 0.0002, 0.0362), (0.0143, 0.0004, 0.0679), (0.0232, 0.0006, 0.1102),
    (0.0435, 0.0012, 0.2074), (0.0776, 0.0022, 0.3713), (0.1344, 0.0040, 0.6456),
    (0.2148, 0.0073, 1.0391), (0.2839, 0.0116, 1.3856), (0.3285, 0.0168, 1.6230),
    (0.3483, 0.0230, 1.7471), (0.3481, 0.0298, 1.7826), (0.3362, 0.0380, 1.7721),
    (0.3187, 0.0480, 1.7441), (0.2908, 0.0600, 1.6692), (0.2511, 0.0739, 1.5281),
    (0.1954, 0.0910, 1.2876), (0.1421, 0.1126, 1.0419), (0.0956, 0.1390, 0.8130),
    (0.0580, 0.1693, 0.6162), (0.0320, 0.2080, 0.4652), (0.0147, 0.2586, 0.3533),
    (0.0049, 0.3230, 0.2720), (0.0024, 0.4073, 0.2123), (0.0093, 0.5030, 0.1582),
    (0.0291, 0.6082, 0.1117), (0.0633, 0.7100, 0.0782), (0.1096, 0.7932, 0.0573),
    (0.1655, 0.8620, 0.0422), (0.2257, 0.9149, 0.0298), (0.2904, 0.9540, 0.0203),
    (0.3597, 0.9803, 0.0134), (0.4334, 0.9950, 0.0087), (0.5121, 1.0000, 0.0057),
    (0.5945, 0.9950, 0.0039), (0.6784, 0.9786, 0.0027), (0.7621, 0.9520, 0.0021),
    (0.8425, 0.9154, 0.0018), (0.9163, 0.8700, 0.0017), (0.9786, 0.8163, 0.0014),
    (1.0263, 0.7570, 0.0011), (1.0567, 0.6949, 0.0010), (1.0622, 0.6310, 0.0008),
    (1.0456, 0.5668, 0.0006), (1.0026, 0.5030, 0.0003), (0.9384, 0.4412, 0.0002),
    (0.8544, 0.3810, 0.0002), (0.7514, 0.3210, 0.0001), (0.6424, 0.2650, 0.0000),
    (0.5419, 0.2170, 0.0000), (0.4479, 0.1750, 0.0000), (0.3608, 0.1382, 0.0000),
    (0.2835, 0.1070, 0.0000), (0.2187, 0.0816, 0.0000), (0.1649, 0.0610, 0.0000),
    (0.1212, 0.0446, 0.0000), (0.0874, 0.0320, 0.0000), (0.0636, 0.0232, 0.0000),
    (0.0468, 0.0170, 0.0000), (0.0329, 0.0119, 0.0000), (0.0227, 0.0082, 0.0000),
    (0.0158, 0.0057, 0.0000), (0.0114, 0.0041, 0.0000), (0.0081, 0.0029, 0.0000),
    (0.0058, 0.0021, 0.0000), (0.0041, 0.0015, 0.0000), (0.0029, 0.0010, 0.0000),
    (0.0020, 0.0007, 0.0000), (0.0014, 0.0005, 0.0000), (0.0010, 0.0004, 0.0000),
    (0.0007, 0.0002, 0.0000), (0.0005, 0.0002, 0.0000), (0.0003, 0.0001, 0.0000),
    (0.0002, 0.0001, 0.0000), (0.0002, 0.0001, 0.0000), (0.0001, 0.0000, 0.0000),
    (0.0001, 0.0000, 0.0000), (0.0001, 0.0000, 0.0000), (0.0000, 0.0000, 0.0000)])


# CIE XYZ (D65) to linear Rec.709, the scene-linear space of Blender's default colour
# configuration (Cycles' init_xyz_transforms default).
XYZ_TO_REC709 = np.array([[3.2404542, -1.5371385, -0.4985314],
                          [-0.9692660, 1.8760108, 0.0415560],
                          [0.0556434, -0.2040259, 1.0572252]])

# The thin-film sensitivity's optical path differences: 0 to 60000 / (2 pi) nm, Cycles'
# table domain (kernel/closure/bsdf_util.h); beyond it Cycles reads its last entry, as
# film_sensitivity does. 1024 entries keep linear interpolation within 2e-4 of the
# integral (the oscillation's period in OPD is the wavelength, ~40 entries).
FILM_OPD_MAX = 60000.0 / (2.0 * np.pi)
FILM_TABLE_SIZE = 1024


def film_sensitivity_table(xyz_to_rgb=XYZ_TO_REC709) -> np.ndarray:
    """(FILM_TABLE_SIZE, 6): for each optical path difference D on [0, FILM_OPD_MAX], the
    integral over wavelength l of each RGB colour-matching function c(l) times
    exp(-2 pi i D / l), over the integral of c: real parts (3) then imaginary parts (3).

    Belcour and Barla (2017) sum a thin film's interference in this Fourier form rather
    than over wavelengths; the m-th term of their Airy series reads it at m D. The
    measure is d(wavelength) and the sign of the exponent negative: that is what Cycles'
    renders match (a thin-film sphere against the closed form: within 5e-4 for a
    dielectric substrate, where only the real part counts, and for a conductor, where the
    opposite sign is 0.13 off; a per-frequency measure is 0.0075 off)."""
    fine = np.arange(380.0, 780.0 + 1e-9, 0.25)
    coarse = 380.0 + 5.0 * np.arange(len(CIE_COLOUR_MATCH))
    cmf = np.stack([np.interp(fine, coarse, CIE_COLOUR_MATCH[:, j]) for j in range(3)], 1)
    rgb = cmf @ np.asarray(xyz_to_rgb, np.float64).T
    opd = np.linspace(0.0, FILM_OPD_MAX, FILM_TABLE_SIZE)
    phase = 2.0 * np.pi * opd[:, None] / fine[None, :]
    norm = rgb.sum(0)
    return np.concatenate([np.cos(phase) @ rgb / norm, -np.sin(phase) @ rgb / norm], 1)

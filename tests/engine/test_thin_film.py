"""The thin film's Fresnel (fresnel.thin_film_dielectric, thin_film_f82; spectrum.py)."""

import os
import subprocess
import sys

import numpy as np
import pytest

from engine import fresnel, spectrum

# Cycles 5.0.1: a smooth Principled UV sphere (256 x 128, smooth shading) seen head-on by an
# orthographic camera under a white world, one bounce, filter width 0.01: each pixel is
# the Fresnel at the cosine of its sphere normal (cos, RGB), read along the middle row.
# Black dielectric of IOR 1.5 under a film of 500 nm and IOR 1.33:
CYCLES_DIELECTRIC = [
    (0.9999, (0.0357, 0.0085, 0.0365)), (0.9662, (0.0406, 0.0097, 0.0343)),
    (0.8953, (0.0472, 0.0164, 0.0263)), (0.8214, (0.0481, 0.0275, 0.0172)),
    (0.7476, (0.0445, 0.0402, 0.0122)), (0.6871, (0.0399, 0.0505, 0.0140)),
    (0.6143, (0.0352, 0.0624, 0.0252)), (0.5242, (0.0352, 0.0777, 0.0540)),
    (0.4390, (0.0472, 0.0972, 0.0966)), (0.3683, (0.0728, 0.1232, 0.1451))]
# Metallic 1, base colour (0.8, 0.5, 0.2), the same film:
METAL_F0 = (0.8, 0.5, 0.2)
CYCLES_METAL = [
    (0.9999, (0.7646, 0.3356, 0.2125)), (0.9662, (0.7872, 0.3234, 0.2252)),
    (0.8953, (0.8203, 0.3272, 0.2256)), (0.8214, (0.8286, 0.3695, 0.1907)),
    (0.7476, (0.8149, 0.4296, 0.1384)), (0.6871, (0.7941, 0.4753, 0.1005)),
    (0.6143, (0.7668, 0.5111, 0.0819)), (0.5242, (0.7388, 0.5193, 0.1170)),
    (0.4390, (0.7170, 0.5013, 0.1985)), (0.3683, (0.6950, 0.4844, 0.2810))]
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
# The rendered normals are the mesh's interpolated ones, the values 4 digits.
TOLERANCE = 1.5e-3


def dielectric(cos, eta=1.5, film_ior=1.33, thickness=500.0):
    return np.array(fresnel.thin_film_dielectric(cos, eta, film_ior, thickness))


def metal(cos, film_ior=1.33, thickness=500.0, f0=METAL_F0, b=(0.0, 0.0, 0.0)):
    return np.array([fresnel.thin_film_f82(cos, f0[c], b[c], film_ior, thickness, c)
                     for c in range(3)])


def test_a_filmed_dielectric_reflects_as_in_cycles():
    for cos, rgb in CYCLES_DIELECTRIC:
        assert np.abs(dielectric(cos) - rgb).max() < TOLERANCE, (cos, dielectric(cos), rgb)


def test_a_filmed_metal_reflects_as_in_cycles():
    for cos, rgb in CYCLES_METAL:
        assert np.abs(metal(cos) - rgb).max() < TOLERANCE, (cos, metal(cos), rgb)


# With another sensitivity table (numba off, so the formulas read the table when called).
_OTHER_TABLE = """
import sys, numpy as np
from engine import fresnel, spectrum
from tests.engine.test_thin_film import CYCLES_DIELECTRIC, CYCLES_METAL, METAL_F0
kind = sys.argv[1]
fine = np.arange(380.0, 780.25, 0.25)
coarse = 380.0 + 5.0 * np.arange(len(spectrum.CIE_COLOUR_MATCH))
cmf = np.stack([np.interp(fine, coarse, spectrum.CIE_COLOUR_MATCH[:, j]) for j in range(3)], 1)
rgb = cmf @ spectrum.XYZ_TO_REC709.T
if kind == "frequency":
    rgb = rgb / fine[:, None] ** 2
sign = 1.0 if kind == "sign" else -1.0
opd = np.linspace(0.0, spectrum.FILM_OPD_MAX, spectrum.FILM_TABLE_SIZE)
phase = 2.0 * np.pi * opd[:, None] / fine[None, :]
fresnel.FILM_SENSITIVITY[:] = np.concatenate([np.cos(phase) @ rgb, sign * np.sin(phase) @ rgb],
                                             1) / np.tile(rgb.sum(0), 2)
off = max(max(abs(fresnel.thin_film_dielectric(c, 1.5, 1.33, 500.0)[k] - v[k]) for k in range(3))
          for c, v in CYCLES_DIELECTRIC)
off_metal = max(abs(fresnel.thin_film_f82(c, METAL_F0[k], 0.0, 1.33, 500.0, k) - v[k])
                for c, v in CYCLES_METAL for k in range(3))
print(off, off_metal)
"""


@pytest.mark.parametrize("kind, dielectric_off, metal_off", [
    ("frequency", 5e-3, 5e-3), ("sign", 0.0, 0.1)])
def test_the_sensitivitys_measure_and_sign_are_what_cycles_renders(kind, dielectric_off,
                                                                   metal_off):
    """The table is integrated over wavelength with exp(-i ...): integrated over frequency
    (each wavelength weighed by 1 / l^2), or with the other sign, the same formulas leave
    Cycles' values by far more than the tolerance (the sign shows only on the metal,
    whose phase shift is complex)."""
    env = dict(os.environ, NUMBA_DISABLE_JIT="1")
    out = subprocess.run([sys.executable, "-c", _OTHER_TABLE, kind], env=env, cwd=ROOT,
                         capture_output=True, text=True, check=True).stdout
    off, off_metal = (float(v) for v in out.split())
    print(kind, off, off_metal)
    assert off >= dielectric_off and off_metal >= metal_off


def test_the_sensitivity_of_no_path_difference_is_one():
    table = spectrum.film_sensitivity_table()
    assert np.allclose(table[0], [1, 1, 1, 0, 0, 0])
    assert np.abs(table[-1]).max() < 0.01  # far beyond the light's coherence


@pytest.mark.parametrize("cos", [1.0, 0.7, 0.3, 0.05])
@pytest.mark.parametrize("eta", [1.5, 0.7])
def test_no_film_and_a_film_of_the_substrates_ior_are_the_plain_fresnel(cos, eta):
    plain = fresnel.fresnel_dielectric(cos, eta, True)[0]
    assert np.allclose(dielectric(cos, eta, 1.8, 0.0), plain, atol=1e-9)
    assert np.allclose(dielectric(cos, eta, eta, 700.0), plain, atol=1e-9)
    b = (0.0, 0.3, -0.2)
    f82 = [fresnel.fresnel_f82(cos, METAL_F0[c], b[c]) for c in range(3)]
    assert np.allclose(metal(cos, 1.8, 0.0, b=b), f82, atol=1e-9)


def test_a_film_is_a_reflectance_everywhere():
    rng = np.random.default_rng(7)
    for _ in range(2000):
        cos, eta, n, d = rng.uniform(0, 1), rng.uniform(0.3, 3), rng.uniform(1, 3), \
            rng.uniform(0, 3000)
        f = dielectric(cos, eta, n, d)
        assert np.all(np.isfinite(f)) and np.all((f >= 0) & (f <= 1)), (cos, eta, n, d, f)
        m = metal(cos, n, d, tuple(rng.uniform(0, 1, 3)), tuple(rng.uniform(-1, 1, 3)))
        assert np.all(np.isfinite(m)) and np.all((m >= 0) & (m <= 1)), (cos, n, d, m)


def test_total_internal_reflection_in_the_film_or_below_it_reflects_everything():
    assert np.all(dielectric(0.3, 1.5, 0.8, 400.0) == 1.0)  # (from inside a film of 0.8)
    assert np.all(dielectric(0.2, 0.6, 1.4, 400.0) == 1.0)  # into a substrate of 0.6


def test_the_specular_tint_scales_a_film_as_far_as_it_lies_below_one():
    f0 = ((1.5 - 1.0) / 2.5) ** 2
    assert fresnel.film_tinted(0.3, 1.5, 1.0) == 0.3
    assert fresnel.film_tinted(1.0, 1.5, 0.2) == 1.0
    assert np.isclose(fresnel.film_tinted(f0, 1.5, 0.5), 0.5 * f0)
    assert np.isclose(fresnel.film_tinted(0.02, 1.5, 0.5), 0.02 * 0.5)  # below F0 too

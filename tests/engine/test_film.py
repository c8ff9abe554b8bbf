"""The film's error estimate: quantiles, the replicate estimate's calibration (with power),
and stopping at a target error. Renders use engine-built scenes and seeded sequences."""

import math

import numpy as np
import pytest
from scipy import stats

from engine import render
from engine import film
from engine.film import _chi2_quantile, _Z975, t95
from tests import scenes

LUM = np.array([0.2126, 0.7152, 0.0722])


def test_t_quantiles_match_scipy():
    for dof in list(range(1, 40)) + [50, 63, 100, 225, 1000, 10 ** 6]:
        assert t95(dof) == pytest.approx(stats.t.ppf(0.975, dof), abs=2e-4), dof
    assert math.isinf(t95(0))


def test_chi_square_quantiles_match_scipy():
    """Wilson-Hilferty is what the image's error interval uses; its degrees of freedom are
    in the hundreds or more for any real image."""
    for dof in (20, 100, 1000, 10 ** 5):
        for z, p in ((_Z975, 0.975), (-_Z975, 0.025)):
            assert _chi2_quantile(z, dof) == pytest.approx(stats.chi2.ppf(p, dof), rel=2e-3)


def _luminance(image):
    return image[..., :3].astype(np.float64) @ LUM


@pytest.fixture(scope="module")
def calibration():
    """CBspheres (glass, mirror, caustics: skewed pixels) at 48x36: a reference of 8192
    samples, then three seeds read at 64 and 256 samples."""
    scene = scenes.cbspheres()
    base = dict(width=48, height=36, max_bounces=8)
    ref = render(scene, scenes.settings(samples=8192, seed=1_000_003, **base))
    reads = {n: [render(scene, scenes.settings(samples=n, seed=seed, **base))
                 for seed in (1, 2, 3)] for n in (64, 256)}
    return ref, reads


def _own_variance(r):
    """Each pixel's own (unpooled, unbiased) replicate variance of its luminance."""
    return film.estimate_of(r, radius=0).error.reshape(r.error.shape).astype(np.float64) ** 2


def _calibration(ref, passes, error_of):
    """(estimated / measured relative RMS error, coverage of the 95% intervals) pooled over
    the passes; the reference's own variance is taken out of the measured error and added
    to each interval. Pixels exact in both renders (the emitter, seen directly) are left out
    of the coverage, as in tests/benchmarks/calibration.py. error_of(p) -> (relative error,
    per-pixel standard error, t)."""
    y_ref = _luminance(ref.combined)
    v_ref = _own_variance(ref)
    est2, meas2, covered = [], [], []
    for p in passes:
        rel, se, t = error_of(p)
        d = _luminance(p.combined) - y_ref
        est2.append(rel ** 2)
        meas2.append((np.mean(d * d) - np.mean(v_ref)) / y_ref.mean() ** 2)
        noisy = ~((d == 0) & (se == 0) & (v_ref == 0))
        covered.append((np.abs(d) <= t * np.sqrt(se ** 2 + v_ref))[noisy])
    return math.sqrt(np.mean(est2) / np.mean(meas2)), float(np.mean(np.concatenate(covered)))


def _replicates(p):
    return p.relative_error, p.error.astype(np.float64), p.t95


@pytest.mark.slow
@pytest.mark.parametrize("samples", [64, 256])
def test_estimated_error_is_the_measured_error(calibration, samples):
    ratio, coverage = _calibration(calibration[0], calibration[1][samples], _replicates)
    assert 0.9 <= ratio <= 1.1, ratio
    assert 0.92 <= coverage <= 0.98, coverage


@pytest.mark.slow
@pytest.mark.parametrize("samples", [64, 256])
def test_the_independent_sample_estimate_fails_the_same_test(calibration, samples):
    """Power: the estimate Specula gave before replicates (the samples' own spread, as if
    they were independent) overstates the error of stratified samples."""
    def independent(p):
        rel = p.independent_relative_error
        mean = _luminance(p.combined).mean()
        return rel, np.full(p.error.shape, rel * mean), 1.96

    ratio, _ = _calibration(calibration[0], calibration[1][samples], independent)
    assert not 0.9 <= ratio <= 1.1, ratio


@pytest.mark.slow
def test_a_render_stops_at_its_target_error():
    scene = scenes.cbspheres()
    base = dict(width=48, height=36, max_bounces=8)
    target = 0.06
    r = render(scene, scenes.settings(samples=100_000, target_error=target, seed=4, **base))
    assert r.stop_reason == "target error"
    ref = render(scene, scenes.settings(samples=16 * r.samples, seed=1_000_003, **base))
    y_ref = _luminance(ref.combined)
    d = _luminance(r.combined) - y_ref
    mse = np.mean(d * d) - np.mean(_own_variance(ref))
    measured = math.sqrt(mse) / y_ref.mean()
    assert abs(measured / target - 1) <= 0.1, (measured, r.samples)


def test_pooling_spreads_rare_paths_and_keeps_what_stands_out():
    """A pixel's interval variance is its 3x3 neighbourhood's mean replicate variance, or,
    where its samples' own spread stands out from its neighbours' (an edge, a highlight),
    that spread scaled by the neighbourhood's replicate/independent ratio."""
    own = np.ones((5, 7))
    independent = np.full((5, 7), 2.0)    # stratification halves the variance here
    own[2, 2] = 0.0                       # replicates that all missed the rare paths
    independent[2, 2] = 0.0
    independent[1, 5] = 200.0             # a highlight: its samples spread 100x more
    out = np.empty((5, 7), np.float32)
    film._pool_variance(own, independent, 1, out)
    assert out[2, 2] == pytest.approx(8 / 9)              # its neighbours' variance
    assert out[1, 5] == pytest.approx(200.0 * 9 / (2 * 8 + 200))  # scaled spread
    assert out[0, 0] == pytest.approx(1.0) and out[4, 6] == pytest.approx(1.0)
    film._pool_variance(own, independent, 0, out)        # radius 0: each pixel's own
    assert np.array_equal(out, own.astype(np.float32))

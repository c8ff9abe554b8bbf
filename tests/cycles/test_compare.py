"""The comparison statistic itself, on synthetic images with known truth (fast, no bpy
rendering): it accepts unbiased noise at about its nominal level and rejects small biases."""

import numpy as np
import pytest

from .compare import block_sums, compare


def _renders(rng, truth, sigma_s, sigma_c, k=2, bias=0.0):
    """Specula mean with its variance, and k Cycles runs, around `truth`."""
    s = truth + bias + rng.normal(0, 1, truth.shape) * sigma_s
    var_s = np.full(truth.shape, sigma_s ** 2)
    runs = truth + rng.normal(0, 1, (k,) + truth.shape) * sigma_c
    return s, var_s, runs


def test_block_sums_cover_partial_blocks():
    img = np.ones((10, 7, 3))
    sums = block_sums(img, 4)
    assert sums.shape == (3, 2, 3)
    assert sums.sum() == img.sum()
    assert sums[0, 0, 0] == 16 and sums[2, 1, 0] == 2 * 3


def test_unbiased_noise_agrees_at_nominal_rate(rng):
    truth = rng.uniform(0.05, 1.0, (48, 64, 3))
    rejections = 0
    trials = 40
    for _ in range(trials):
        s, v, runs = _renders(rng, truth, 0.05, 0.03)
        rejections += not compare(s, v, runs, alpha=0.05).agree
    # Family level 5 %: expect about 2 of 40; 8 would be a p < 0.001 excess.
    assert rejections <= 8


@pytest.mark.parametrize("bias, region", [(0.02, np.s_[:, :, :]), (0.1, np.s_[8:12, 20:24, 1])])
def test_small_bias_is_rejected(rng, bias, region):
    truth = rng.uniform(0.05, 1.0, (48, 64, 3))
    s, v, runs = _renders(rng, truth, 0.05, 0.03)
    s[region] += bias
    c = compare(s, v, runs)
    assert not c.agree, c.describe()


def test_equal_noise_free_images_agree_and_differences_do_not():
    img = np.zeros((16, 16, 3))
    img[4:8, 4:8] = 10.0  # an emitter seen directly: no variance anywhere
    zero = np.zeros_like(img)
    assert compare(img, zero, np.stack([img, img])).agree
    other = img.copy()
    other[5, 5, 0] = 9.0
    assert not compare(other, zero, np.stack([img, img])).agree


def test_needs_two_cycles_runs():
    img = np.zeros((8, 8, 3))
    with pytest.raises(ValueError, match="two Cycles runs"):
        compare(img, img, img[None])

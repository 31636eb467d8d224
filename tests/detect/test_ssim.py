"""SSIM maps against scikit-image and Wang's definition; the seed's Fig 4.3 behaviour."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from skimage import data
from skimage.metrics import structural_similarity

from tracker_detect.ssim import (
    SsimParams,
    auto_downsample_factor,
    box_statistics,
    downsample,
    gaussian_window,
    mean_ssim,
    simplified_ssim,
    ssim_map,
)

BORDER = 5  # half of the 11 px window: the 'valid' interior starts here


def skimage_map(x, y):
    _, full = structural_similarity(
        x,
        y,
        gaussian_weights=True,
        sigma=1.5,
        use_sample_covariance=False,
        data_range=255,
        full=True,
    )
    return full


def real_pairs():
    """Pairs of real photographs: a camera shake (shift + noise), a lighting change, a new object."""
    rng = np.random.default_rng(0)
    camera = data.camera()
    shaken = np.roll(camera, (2, -3), axis=(0, 1))
    noisy = np.clip(shaken + rng.normal(0, 6, camera.shape), 0, 255).astype(np.uint8)
    astronaut = cv2.cvtColor(data.astronaut(), cv2.COLOR_RGB2GRAY)
    darker = cv2.convertScaleAbs(astronaut, alpha=0.8, beta=10)
    coffee = cv2.cvtColor(data.coffee(), cv2.COLOR_RGB2GRAY)
    intruder = coffee.copy()
    intruder[100:220, 200:330] = camera[50:170, 300:430]
    return [(camera, noisy), (astronaut, darker), (coffee, intruder)]


@pytest.mark.parametrize("pair", range(3))
def test_map_matches_scikit_image_on_real_frames(pair):
    x, y = real_pairs()[pair]
    ours = ssim_map(x, y)
    reference = skimage_map(x, y)
    assert ours.shape == x.shape and ours.dtype == np.float32
    interior = np.s_[BORDER:-BORDER, BORDER:-BORDER]
    assert np.max(np.abs(ours[interior] - reference[interior])) < 1e-3
    # skimage pads by reflection too, so even the borders agree
    assert np.max(np.abs(ours - reference)) < 1e-3


def test_valid_map_is_the_interior_of_the_full_map():
    x, y = real_pairs()[0]
    full = ssim_map(x, y)
    valid = ssim_map(x, y, valid=True)
    assert valid.shape == (x.shape[0] - 10, x.shape[1] - 10)
    np.testing.assert_allclose(valid, full[BORDER:-BORDER, BORDER:-BORDER], atol=1e-6)


def test_map_follows_wangs_formula_in_float64():
    """A direct double-precision transcription of ssim.m (filter2 'valid', biased statistics)."""
    rng = np.random.default_rng(1)
    x = rng.integers(0, 256, (40, 50)).astype(np.float64)
    y = np.clip(x + rng.normal(0, 25, x.shape), 0, 255)
    g = gaussian_window().astype(np.float64)
    w = np.outer(g, g)

    def filter_valid(img):
        out = np.empty((img.shape[0] - 10, img.shape[1] - 10))
        for i in range(out.shape[0]):
            for j in range(out.shape[1]):
                out[i, j] = np.sum(w * img[i : i + 11, j : j + 11])
        return out

    c1, c2 = (0.01 * 255) ** 2, (0.03 * 255) ** 2
    mu1, mu2 = filter_valid(x), filter_valid(y)
    s1 = filter_valid(x * x) - mu1**2
    s2 = filter_valid(y * y) - mu2**2
    s12 = filter_valid(x * y) - mu1 * mu2
    expected = ((2 * mu1 * mu2 + c1) * (2 * s12 + c2)) / ((mu1**2 + mu2**2 + c1) * (s1 + s2 + c2))
    np.testing.assert_allclose(ssim_map(x, y, valid=True), expected, atol=2e-5)
    assert np.isclose(np.sum(w), 1.0)
    assert SsimParams().c1 == pytest.approx(6.5025) and SsimParams().c2 == pytest.approx(58.5225)


def test_identical_images_score_one_everywhere():
    x = data.camera()[:100, :120]
    np.testing.assert_allclose(ssim_map(x, x), 1.0, atol=1e-5)


def test_automatic_downsampling_factor_as_ssim_m():
    assert auto_downsample_factor((240, 320)) == 1  # the seed's clips: no downsampling
    assert auto_downsample_factor((110, 110)) == 1
    assert auto_downsample_factor((576, 768)) == 2
    assert auto_downsample_factor((384, 500)) == 2  # 1.5 rounds away from zero, as MATLAB
    assert auto_downsample_factor((1080, 1920)) == 4


def test_downsampling_by_two_takes_block_means():
    rng = np.random.default_rng(2)
    x = rng.integers(0, 256, (8, 10)).astype(np.float32)
    expected = x.reshape(4, 2, 5, 2).mean(axis=(1, 3))
    np.testing.assert_allclose(downsample(x, 2), expected, atol=1e-4)


def test_downsampled_map_is_the_map_of_downsampled_images():
    x, y = real_pairs()[2]
    np.testing.assert_allclose(
        ssim_map(x, y, downsample_factor=2),
        ssim_map(downsample(x, 2), downsample(y, 2)),
        atol=1e-6,
    )
    assert mean_ssim(x, y) == pytest.approx(
        float(np.mean(ssim_map(downsample(x, 2), downsample(y, 2), valid=True))), abs=1e-6
    )


def test_rejects_mismatched_or_tiny_images():
    with pytest.raises(ValueError, match="equal-size"):
        ssim_map(np.zeros((20, 20)), np.zeros((20, 21)))
    with pytest.raises(ValueError, match="smaller"):
        ssim_map(np.zeros((8, 30)), np.zeros((8, 30)))
    with pytest.raises(ValueError):
        SsimParams(win_size=10)


def fig_4_3_image():
    """A synthetic test picture: smooth structure plus fine texture, grey levels 0-255."""
    rng = np.random.default_rng(7)
    yy, xx = np.mgrid[0:240, 0:320]
    texture = cv2.GaussianBlur(rng.standard_normal((240, 320)), (0, 0), 1.5)
    picture = 128 + 70 * np.sin(xx / 9.0) * np.cos(yy / 13.0) + 90 * texture
    return np.clip(picture, 0, 255).round()


def test_seed_fig_4_3_structure_matters_not_mse():
    """Equal-MSE distortions (seed Fig 4.3, after Wang et al.): contrast and luminance changes keep
    the structure and score high; Gaussian noise destroys it and scores low."""
    x = fig_4_3_image()
    rng = np.random.default_rng(8)
    mse_target = 306.0
    gain = 1 + np.sqrt(mse_target) / x.std()
    contrast = np.clip(np.round(x.mean() + gain * (x - x.mean())), 0, 255)
    luminance = np.clip(x + np.sqrt(mse_target), 0, 255)
    noise = np.clip(np.round(x + rng.normal(0, np.sqrt(mse_target), x.shape)), 0, 255)
    results = {}
    for name, y in (("contrast", contrast), ("luminance", luminance), ("noise", noise)):
        mse = float(np.mean((x - y) ** 2))
        assert mse == pytest.approx(mse_target, rel=0.06), name
        results[name] = mean_ssim(x, y)
    # the seed quotes 0.928 / 0.987 / 0.576 for its (Einstein) picture
    assert 0.88 < results["contrast"] < 0.97
    assert results["luminance"] > 0.97
    assert results["noise"] < 0.65
    assert results["noise"] < results["contrast"] < results["luminance"]


def test_box_statistics_are_local_mean_and_std():
    rng = np.random.default_rng(3)
    x = rng.integers(0, 256, (20, 30)).astype(np.float64)
    stats = box_statistics(x, window=5)
    assert stats.shape == (16, 26)
    windows = np.lib.stride_tricks.sliding_window_view(x, (5, 5))
    np.testing.assert_allclose(stats.mean, windows.mean(axis=(2, 3)), atol=1e-3)
    np.testing.assert_allclose(stats.std, windows.std(axis=(2, 3)), atol=1e-2)


def test_simplified_ssim_is_luminance_times_contrast():
    rng = np.random.default_rng(4)
    ma, mb = rng.uniform(0, 255, (2, 10, 10))
    sa, sb = rng.uniform(0, 60, (2, 10, 10))
    c1, c2 = 6.5025, 58.5225
    expected = (
        (2 * ma * mb + c1) * (2 * sa * sb + c2) / ((ma**2 + mb**2 + c1) * (sa**2 + sb**2 + c2))
    )
    got = simplified_ssim(*(a.astype(np.float32) for a in (ma, sa, mb, sb)))
    np.testing.assert_allclose(got, expected, rtol=1e-5)


def test_float_images_with_their_own_data_range():
    """Images scaled to [0, 1] with data_range=1 give the same map as their 8-bit originals."""
    x, y = real_pairs()[0]
    scaled = ssim_map(x / 255.0, y / 255.0, SsimParams(data_range=1.0))
    reference = structural_similarity(
        x / 255.0,
        y / 255.0,
        gaussian_weights=True,
        sigma=1.5,
        use_sample_covariance=False,
        data_range=1.0,
        full=True,
    )[1]
    np.testing.assert_allclose(scaled[5:-5, 5:-5], reference[5:-5, 5:-5], atol=1e-3)
    np.testing.assert_allclose(scaled, ssim_map(x, y), atol=5e-4)

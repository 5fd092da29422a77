"""Thresholds: each strategy finds the markings; the default shrugs off shadows and seams."""

from __future__ import annotations

import numpy as np
import pytest

from lanefinder.config import BirdseyeConfig, Config, StreaksConfig, ThresholdConfig
from lanefinder.pipeline import LaneFinder
from lanefinder.threshold import streaks, threshold


@pytest.fixture(scope="module")
def warped(test_images):
    be = LaneFinder(Config()).birdseye((1280, 720))
    return {k: be.warp(v) for k, v in test_images.items()}


XM = BirdseyeConfig().xm_per_px  # metres per bird's-eye pixel across the road, default set-up


def _near_lines(mask: np.ndarray, xs=(125, 275), half: int = 10) -> float:
    near = sum(int(mask[:, x - half:x + half].sum()) for x in xs)
    return near / max(1, int(mask.sum()))


@pytest.mark.parametrize("strategy", ["ridge", "sobel-hls", "color", "ycrcb"])
def test_every_strategy_finds_the_straight_lines(strategy, warped):
    cfg = ThresholdConfig(strategy=strategy)
    mask = threshold(warped["straight_lines1"], cfg, XM)
    assert mask.dtype == np.uint8 and set(np.unique(mask)) <= {0, 1}
    # Both line columns hold markings over much of the height.
    for x in (125, 275):
        rows_hit = (mask[:, x - 8:x + 8].sum(axis=1) > 0).mean()
        assert rows_hit > (0.2 if x == 275 else 0.8), (strategy, x, rows_hit)  # right: dashed


def test_ridge_is_mostly_lines(warped):
    mask = threshold(warped["straight_lines1"], ThresholdConfig(), XM)
    assert _near_lines(mask) > 0.8  # measured 0.9


def test_ridge_ignores_shadow_edges_and_seams():
    road = np.full((200, 400, 3), 90, np.uint8)
    road[:, 100:110] = 200  # a white line
    road[:, 250:] = 140  # a pavement seam: a one-sided step
    road[100:, :] = (road[100:, :] * 0.35).astype(np.uint8)  # a hard shadow over the lower half
    mask = threshold(road, ThresholdConfig(), XM)
    assert mask[:, 100:110].mean() > 0.95  # the line, in sun and in shade
    assert mask[:, 120:400].sum() == 0  # no seam, no shadow edge


def test_ridge_finds_yellow_on_pale_concrete():
    road = np.full((100, 300, 3), (170, 180, 185), np.uint8)  # BGR pale concrete
    road[:, 150:158] = (40, 190, 220)  # yellow paint, little brighter than the concrete
    mask = threshold(road, ThresholdConfig(), XM)
    assert mask[:, 150:158].mean() > 0.9 and mask[:, :140].sum() == 0


def test_a_cap_on_the_relative_test_finds_faint_white_on_light_concrete():
    # Worn white paint on light concrete (grey 180) is 20 levels lighter: under the relative test
    # (0.18 of the road, 32 levels), over a cap of 16 (the second look for faint paint).
    road = np.full((100, 300, 3), 180, np.uint8)
    road[:, 150:156] = 200
    plain = ThresholdConfig()
    capped = ThresholdConfig.model_validate({"ridge": {"rel_contrast_max": plain.ridge.faint_contrast_max}})
    assert threshold(road, plain, XM).sum() == 0
    mask = threshold(road, capped, XM)
    assert mask[:, 150:156].mean() > 0.9 and mask[:, :140].sum() == 0


def _line(b: np.ndarray, x_of_y) -> None:
    """Draw a 5 px wide line x(y) into a bird's-eye binary (y: rows from the top)."""
    y = np.arange(b.shape[0])
    x = np.round(x_of_y(y.astype(float))).astype(int)
    for dx in range(-2, 3):
        ok = (x + dx >= 0) & (x + dx < b.shape[1])
        b[y[ok], x[ok] + dx] = 1


def test_streaks_pointing_at_the_camera_are_taken_out_and_lane_lines_kept():
    # The default view's scale: 400x300 px, 0.025 m across and 0.1 m along a pixel; the camera
    # 6 m behind the bottom row, below column 200.
    xm, ym, foot = 0.025, 0.1, (200.0, 360.0)
    lanes = np.zeros((300, 400), np.uint8)
    _line(lanes, lambda y: 126 + 0 * y)                                  # straight, 1.85 m left
    _line(lanes, lambda y: 274 + ((300 - y) * ym) ** 2 / (2 * 100) / xm)  # right line of a bend, R 100 m
    _line(lanes, lambda y: 200 + (360 - y) * 0.05)                       # a line passing under the car
    assert not streaks(lanes, foot, xm, ym, StreaksConfig()).any()
    wet = lanes.copy()
    _line(wet, lambda y: 200 + (360 - y) * 0.5)  # a lamp's reflection, 0.75 m right at the bottom
    found = streaks(wet, foot, xm, ym, StreaksConfig())
    assert found.sum() > 0.9 * (wet.sum() - lanes.sum())
    assert (found & (lanes > 0)).sum() < 40  # of the lane lines, only where the streak crosses one
    assert not streaks(wet, foot, xm, ym, StreaksConfig(min_run_m=40.0)).any()  # no fan that long: none

"""Following a line beyond the bird's-eye view (lanefinder.farfield): what stray pixels and missed dashes do."""

from __future__ import annotations

import numpy as np
import pytest

from lanefinder import LaneFinder
from lanefinder.config import FarConfig
from lanefinder.farfield import follow_line, make_farview
from lanefinder.geometry import poly_x

FIT = np.array([0.0, 0.0, 300.0])  # a straight line 300 px across the bird's-eye view


@pytest.fixture(scope="module")
def farview():
    be = LaneFinder().birdseye((1280, 720))
    return make_farview(be, FarConfig()), be.xm_per_px


def _marking(fv, keep) -> np.ndarray:
    """A far binary with a 5-column marking on the fit's extension, in the rows ``keep(d_m)`` says."""
    binary = np.zeros((len(fv.v_px), fv.width), np.uint8)
    for k, (v, d) in enumerate(zip(fv.v_px, fv.d_m, strict=True)):
        if keep(d):
            col = round(float(poly_x(FIT, v)) - fv.u0_px)
            binary[k, col - 2:col + 3] = 1
    return binary


def test_a_stray_pixel_in_the_first_far_row_does_not_steer_the_search_off_the_line(farview):
    fv, xm = farview
    binary = _marking(fv, lambda d: d > 33.0)
    near = len(fv.v_px) - 1  # the first far row: a stray pixel at the window's edge, none of the marking
    col = round(float(poly_x(FIT, fv.v_px[near])) - fv.u0_px)
    binary[near, col - 14] = 1
    far = follow_line(binary, fv, FIT, xm, FarConfig())
    assert far is not None and far.range_m > 90
    v = np.linspace(far.end_px, 0, 20)
    assert np.abs(poly_x(far.fit_px, v) - poly_x(FIT, v)).max() < 2.0  # px
    # Without the anchor the stray pixel is taken for a slope and the search leaves the line.
    lost = follow_line(binary, fv, FIT, xm, FarConfig(anchor_m=0.0))
    assert lost is None or lost.range_m < 60 or np.abs(poly_x(lost.fit_px, v) - poly_x(FIT, v)).max() > 20


def test_a_missed_dash_far_ahead_is_crossed_but_a_longer_blank_is_not(farview):
    fv, xm = farview
    binary = _marking(fv, lambda d: d < 45.0 or d > 70.0)  # 25 m without marking: two dash periods
    far = follow_line(binary, fv, FIT, xm, FarConfig())
    assert far is not None and far.range_m > 90
    assert follow_line(binary, fv, FIT, xm, FarConfig(max_gap_m=15.0)).range_m < 46
    longer = _marking(fv, lambda d: d < 35.0 or d > 80.0)  # 45 m without marking: more than max_gap_m
    assert follow_line(longer, fv, FIT, xm, FarConfig()).range_m < 36


def test_scattered_texture_along_the_extension_is_no_far_part(farview):
    fv, xm = farview
    for seed in range(10):
        rng = np.random.default_rng(seed)
        binary = np.zeros((len(fv.v_px), fv.width), np.uint8)
        for k, (v, d) in enumerate(zip(fv.v_px, fv.d_m, strict=True)):  # blobs anywhere in the search window
            half_m = 0.35 + 0.01 * (d - fv.d_m[-1])
            col = round(float(poly_x(FIT, v)) - fv.u0_px + rng.uniform(-half_m, half_m) / xm)
            binary[k, col - 2:col + 3] = 1
        assert follow_line(binary, fv, FIT, xm, FarConfig()) is None, seed
        assert follow_line(binary, fv, FIT, xm, FarConfig(max_scatter_m=0.0)) is not None  # without the test: kept
    assert follow_line(_marking(fv, lambda d: True), fv, FIT, xm, FarConfig()) is not None  # paint is kept


def test_texture_is_seldom_taken_for_a_changing_bend(farview):
    # Blobs anywhere in the search window, from the near view's edge over 27 rows (the whole far view) or
    # 12. Kept, of 100 draws each: 5 and 21 with the parabola's test alone, 10 and 34 with a cubic
    # allowed on any rows, 6 and 23 now (a cubic over 8 rows or more that takes half the scatter away).
    fv, xm = farview
    k_rows = len(fv.v_px)
    for n_rows, most in ((27, 7), (12, 25)):
        kept = 0
        for seed in range(100):
            rng = np.random.default_rng(seed)
            binary = np.zeros((k_rows, fv.width), np.uint8)
            for k in range(k_rows - 1, k_rows - 1 - n_rows, -1):
                half_m = 0.35 + 0.01 * (fv.d_m[k] - fv.d_m[-1])
                col = round(float(poly_x(FIT, fv.v_px[k])) - fv.u0_px + rng.uniform(-half_m, half_m) / xm)
                binary[k, col - 2:col + 3] = 1
            kept += follow_line(binary, fv, FIT, xm, FarConfig()) is not None
        assert kept <= most, (n_rows, kept)


def test_a_marking_whose_bend_changes_along_the_road_is_no_texture(farview):
    # A bend that tightens beyond the view: the marking leaves the near fit's extension as a cubic,
    # 7 m to the side 96 m ahead. Its rows lie 0.16 m (median) from the correction's parabola,
    # beyond far.max_scatter_m, but within 0.01 m of a cubic: paint, kept (it was dropped as texture before).
    fv, xm = farview
    s_max = float(-fv.v_px.min())
    binary = np.zeros((len(fv.v_px), fv.width), np.uint8)
    for k, v in enumerate(fv.v_px):
        col = round(float(poly_x(FIT, v)) - fv.u0_px + 7.0 / xm * (-v / s_max) ** 3)
        binary[k, col - 2:col + 3] = 1
    far = follow_line(binary, fv, FIT, xm, FarConfig())
    assert far is not None and far.range_m > 90
    off_m = (float(poly_x(far.fit_px, far.end_px) - poly_x(FIT, far.end_px)) * xm)
    assert abs(off_m - 7.0 * (-far.end_px / s_max) ** 3) < 1.0  # the far part's end, on the marking within 1 m


def test_the_far_view_ends_where_the_frame_no_longer_resolves_a_marking():
    # A metre across the road must span far.min_px_per_m (8) frame pixels: at 1280x720 the
    # whole view (96 m), at 640x360 about 62 m. Measured at 640x360 on tuning seeds 0-10: 0.9476
    # without the limit (below the 0.9487 of the shorter search before), 0.9520 with it.
    finder = LaneFinder()
    full = make_farview(finder.birdseye((1280, 720)), FarConfig())
    assert full.d_m[0] > 90 and len(full.v_px) == len(make_farview(finder.birdseye((1280, 720)),
                                                                    FarConfig(min_px_per_m=0)).v_px)
    small = make_farview(LaneFinder().birdseye((640, 360)), FarConfig())
    assert 55 < small.d_m[0] < 70
    assert make_farview(LaneFinder().birdseye((640, 360)), FarConfig(min_px_per_m=0)).d_m[0] > 85

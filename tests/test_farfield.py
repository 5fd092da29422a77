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
    assert np.abs(poly_x(far.fit_px, v) - poly_x(FIT, v)).max() < 2.0  # px; without the anchor: 290
    # Without the anchor the stray pixel is taken for a slope and the search leaves the line.
    lost = follow_line(binary, fv, FIT, xm, FarConfig(anchor_m=0.0))
    assert lost is None or lost.range_m < 60 or np.abs(poly_x(lost.fit_px, v) - poly_x(FIT, v)).max() > 20


def test_a_missed_dash_far_ahead_is_crossed_but_a_longer_blank_is_not(farview):
    fv, xm = farview
    binary = _marking(fv, lambda d: d < 45.0 or d > 70.0)  # 25 m without marking: two dash periods
    far = follow_line(binary, fv, FIT, xm, FarConfig())
    assert far is not None and far.range_m > 90
    assert follow_line(binary, fv, FIT, xm, FarConfig(max_gap_m=15.0)).range_m < 46


def test_scattered_texture_along_the_extension_is_no_far_part(farview):
    fv, xm = farview
    rng = np.random.default_rng(5)
    binary = np.zeros((len(fv.v_px), fv.width), np.uint8)
    for k, v in enumerate(fv.v_px):  # blobs anywhere within 0.3 m of the line
        col = round(float(poly_x(FIT, v)) - fv.u0_px + rng.uniform(-0.3, 0.3) / xm)
        binary[k, col - 2:col + 3] = 1
    assert follow_line(binary, fv, FIT, xm, FarConfig()) is None
    assert follow_line(binary, fv, FIT, xm, FarConfig(max_scatter_m=0.0)) is not None  # without the test: kept
    assert follow_line(_marking(fv, lambda d: True), fv, FIT, xm, FarConfig()) is not None  # paint is kept


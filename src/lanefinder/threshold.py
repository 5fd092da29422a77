"""Lane-marking pixels: strategies from a BGR uint8 image to a binary mask (uint8 0/1).

Every strategy is a plain function ``f(image, cfg) -> mask``; :func:`threshold`
picks one by the name in the configuration.  The pipeline applies them to the
bird's-eye image, where a marking has the same width (in pixels) near and far.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import cv2
import numpy as np

from .config import ColorConfig, RidgeConfig, SobelHlsConfig, StreaksConfig, ThresholdConfig, YcrcbConfig

__all__ = ["BLOWN_OUT_LEVEL", "STRATEGIES", "blown_out", "blown_out_rows", "color", "ridge", "rowwise", "sobel_hls",
           "streak_points", "streaks", "threshold", "ycrcb"]

#: A pixel at least this bright in every channel is blown out (glare): no paint can be told from
#: the road there.
BLOWN_OUT_LEVEL = 245

# The ridge window is at least this wide (pixels): narrower cannot hold a road level either side.
_MIN_RIDGE_WINDOW_PX = 3


def _in_range(channel: np.ndarray, lo_hi: tuple[float, float]) -> np.ndarray:
    lo, hi = lo_hi
    return (channel >= lo) & (channel <= hi)


def _scaled_abs(grad: np.ndarray) -> np.ndarray:
    """|gradient| scaled to 0..255 by its maximum (the classroom convention)."""
    a = np.abs(grad)
    peak = float(a.max())
    return (a * (255.0 / peak)).astype(np.uint8) if peak > 0 else np.zeros(a.shape, np.uint8)


def sobel_hls(image: np.ndarray, cfg: SobelHlsConfig) -> np.ndarray:
    """S of HLS: Sobel x AND y, or magnitude AND direction, OR an S colour band.

    Right for well-lit roads with saturated (yellow) lines; weak in shadows and on pale concrete.

    Parameters
    ----------
    image : (H, W, 3) uint8 ndarray
        BGR image (the bird's-eye view, in the pipeline).
    cfg : SobelHlsConfig
        The strategy's levels.

    Returns
    -------
    (H, W) uint8 ndarray
        1 on marking pixels, 0 elsewhere.

    Examples
    --------
    >>> from lanefinder.config import SobelHlsConfig
    >>> img = np.full((20, 40, 3), 90, np.uint8); img[:, 18:22] = (40, 220, 240)
    >>> sobel_hls(img, SobelHlsConfig())[5, 15:25]
    array([0, 0, 1, 1, 1, 1, 1, 1, 0, 0], dtype=uint8)
    """
    s = cv2.cvtColor(image, cv2.COLOR_BGR2HLS)[..., 2]
    gx = cv2.Sobel(s, cv2.CV_32F, 1, 0, ksize=cfg.kernel)
    gy = cv2.Sobel(s, cv2.CV_32F, 0, 1, ksize=cfg.kernel)
    mag = _scaled_abs(cv2.magnitude(gx, gy))
    direction = np.arctan2(np.abs(gy), np.abs(gx))
    grad = (_in_range(_scaled_abs(gx), cfg.x_thresh) & _in_range(_scaled_abs(gy), cfg.y_thresh)) | (
        _in_range(mag, cfg.mag_thresh) & _in_range(direction, cfg.dir_thresh)
    )
    return (grad | _in_range(s, cfg.s_thresh)).astype(np.uint8)


def color(image: np.ndarray, cfg: ColorConfig) -> np.ndarray:
    """White from L of HLS or L of LUV, yellow from b of Lab.

    Right for clean, evenly lit roads; fixed levels fail in deep shade and in glare.

    Parameters
    ----------
    image : (H, W, 3) uint8 ndarray
        BGR image (the bird's-eye view, in the pipeline).
    cfg : ColorConfig
        The strategy's levels.

    Returns
    -------
    (H, W) uint8 ndarray
        1 on marking pixels, 0 elsewhere.

    Examples
    --------
    >>> from lanefinder.config import ColorConfig
    >>> img = np.full((20, 40, 3), 90, np.uint8); img[:, 18:22] = (40, 220, 240)
    >>> color(img, ColorConfig())[5, 15:25]
    array([0, 0, 0, 1, 1, 1, 1, 0, 0, 0], dtype=uint8)
    """
    hls_l = cv2.cvtColor(image, cv2.COLOR_BGR2HLS)[..., 1]
    luv_l = cv2.cvtColor(image, cv2.COLOR_BGR2LUV)[..., 0]
    lab_b = cv2.cvtColor(image, cv2.COLOR_BGR2LAB)[..., 2]
    return (_in_range(hls_l, cfg.hls_l) | _in_range(luv_l, cfg.luv_l) | _in_range(lab_b, cfg.lab_b)).astype(np.uint8)


def ycrcb(image: np.ndarray, cfg: YcrcbConfig) -> np.ndarray:
    """Sobel x on Y of YCrCb, OR Y of YUV, OR R of RGB.

    Right for bright white lines on dark asphalt; gradients also fire on seams and shadow edges.

    Parameters
    ----------
    image : (H, W, 3) uint8 ndarray
        BGR image (the bird's-eye view, in the pipeline).
    cfg : YcrcbConfig
        The strategy's levels.

    Returns
    -------
    (H, W) uint8 ndarray
        1 on marking pixels, 0 elsewhere.

    Examples
    --------
    >>> from lanefinder.config import YcrcbConfig
    >>> img = np.full((20, 40, 3), 90, np.uint8); img[:, 18:22] = (40, 220, 240)
    >>> ycrcb(img, YcrcbConfig())[5, 15:25]
    array([0, 0, 1, 1, 1, 1, 1, 1, 0, 0], dtype=uint8)
    """
    y = cv2.cvtColor(image, cv2.COLOR_BGR2YCrCb)[..., 0]
    yuv_y = cv2.cvtColor(image, cv2.COLOR_BGR2YUV)[..., 0]
    gx = _scaled_abs(cv2.Sobel(y, cv2.CV_32F, 1, 0, ksize=cfg.kernel))
    r = image[..., 2]
    return (_in_range(gx, cfg.ycrcb_y_grad) | _in_range(yuv_y, cfg.yuv_y) | _in_range(r, cfg.rgb_r)).astype(np.uint8)


#: Top-hat values above this count as this much when measuring the texture (a marking's own
#: contrast must not raise its threshold much).
_GRAIN_CAP = 16
#: The texture patch is this fraction of the view's height tall (3 m of a 30 m view).
_GRAIN_ROWS = 10


def ridge(image: np.ndarray, cfg: RidgeConfig, xm_per_px: float) -> np.ndarray:
    """Find markings as horizontal ridges of lightness (white and yellow) or of yellowness.

    Lightness is the green channel (close to luminance, high on white and yellow paint);
    yellowness is red minus blue.  The top-hat ``v - opening(v)`` over a ``width_m`` wide
    window keeps only features narrower than the window and brighter than the road on
    *both* sides.  A shadow edge or a pavement seam is a one-sided step: its top-hat is zero.
    The lightness test is relative to the local road level, so a line in shade passes and
    sunlit texture does not, and to the texture around the pixel (``noise_factor`` times the
    mean top-hat of a patch ``noise_patch_m`` wide), so the grain of rough asphalt, cracks
    and grass does not.  Right for the bird's-eye image of any road; the default.

    Parameters
    ----------
    image : (H, W, 3) uint8 ndarray
        BGR image (the bird's-eye view, in the pipeline).
    cfg : RidgeConfig
        Window width (m) and contrast levels.
    xm_per_px : float
        Metres per pixel across the road: sizes the window.

    Returns
    -------
    (H, W) uint8 ndarray
        1 on marking pixels, 0 elsewhere.

    Examples
    --------
    >>> from lanefinder.config import RidgeConfig
    >>> img = np.full((20, 40, 3), 90, np.uint8); img[:, 18:22] = 220
    >>> ridge(img, RidgeConfig(), 0.025)[5, 15:25]
    array([0, 0, 0, 1, 1, 1, 1, 0, 0, 0], dtype=uint8)
    """
    blue, light, red = cv2.split(image)
    yellow = cv2.subtract(red, blue)
    width = max(_MIN_RIDGE_WINDOW_PX, round(cfg.width_m / xm_per_px)) | 1  # odd: a symmetric window keeps steps exact
    kernel = cv2.getStructuringElement(cv2.MORPH_RECT, (width, 1))
    road = cv2.morphologyEx(light, cv2.MORPH_OPEN, kernel)
    top = cv2.subtract(light, road)
    # contrast > max(min_contrast, min(rel_contrast * road, rel_contrast_max)): integer images throughout.
    rel = cv2.convertScaleAbs(road, alpha=cfg.rel_contrast)
    if cfg.rel_contrast_max < 255:
        rel = cv2.min(rel, int(cfg.rel_contrast_max))
    need = cv2.max(rel, int(cfg.min_contrast))
    if cfg.noise_factor > 0:
        # The texture around each pixel: the mean top-hat over a patch (capped, so that a
        # marking inside the patch raises it little), times noise_factor.
        box = (max(3, round(cfg.noise_patch_m / xm_per_px)) | 1, max(3, image.shape[0] // _GRAIN_ROWS) | 1)
        grain = cv2.boxFilter(cv2.min(top, _GRAIN_CAP), -1, box, borderType=cv2.BORDER_REFLECT)
        need = cv2.max(need, cv2.convertScaleAbs(grain, alpha=cfg.noise_factor))
    white = cv2.compare(top, need, cv2.CMP_GT)
    ytop = cv2.subtract(yellow, cv2.morphologyEx(yellow, cv2.MORPH_OPEN, kernel))
    yel = cv2.compare(ytop, int(cfg.yellow_min_contrast), cv2.CMP_GT) & cv2.compare(
        yellow, int(cfg.yellow_min), cv2.CMP_GT
    )
    return cv2.bitwise_or(white, yel) // 255


#: The strategies by name: (function, its config section).
STRATEGIES: dict[str, tuple[Callable[[np.ndarray, object], np.ndarray], str]] = {
    "ridge": (ridge, "ridge"),
    "sobel-hls": (sobel_hls, "sobel_hls"),
    "color": (color, "color"),
    "ycrcb": (ycrcb, "ycrcb"),
}


def blown_out(image: np.ndarray) -> np.ndarray:
    """Mark an image's blown-out pixels: at least ``BLOWN_OUT_LEVEL`` in every channel (glare).

    Parameters
    ----------
    image : (H, W, 3) uint8 ndarray
        BGR image.

    Returns
    -------
    (H, W) uint8 ndarray
        255 on blown-out pixels, 0 elsewhere.

    Examples
    --------
    >>> img = np.full((1, 3, 3), 250, np.uint8); img[0, 1, 0] = 200
    >>> blown_out(img).tolist()
    [[255, 0, 255]]
    """
    return cv2.inRange(image, (BLOWN_OUT_LEVEL,) * 3, (255, 255, 255))


def blown_out_rows(image: np.ndarray, fraction: float = 0.5) -> np.ndarray:
    """Tell which rows of an image are blown out: at least ``fraction`` of their pixels (glare).

    A pixel is blown out when it is at least ``BLOWN_OUT_LEVEL`` in every channel (:func:`blown_out`).

    Parameters
    ----------
    image : (H, W, 3) uint8 ndarray
        BGR image (the bird's-eye view, in the pipeline).
    fraction : float, optional
        The share of a row's pixels that must be blown out.

    Returns
    -------
    (H,) bool ndarray
        True on the blown-out rows.

    Examples
    --------
    >>> img = np.full((4, 10, 3), 90, np.uint8); img[1, :6] = 255; img[2, :4] = 255
    >>> blown_out_rows(img).tolist()
    [False, True, False, False]
    """
    share = cv2.reduce(blown_out(image), 1, cv2.REDUCE_AVG, dtype=cv2.CV_32F)[:, 0] / 255.0
    return share >= fraction


def rowwise(cfg: ThresholdConfig) -> bool:
    """Tell whether a threshold decides each row from that row alone.

    Images stacked one below the other may then be thresholded in one call: ``ridge`` without
    its texture test works along rows only; the other strategies filter across rows.

    Parameters
    ----------
    cfg : ThresholdConfig
        The settings.

    Returns
    -------
    bool
        True for ``ridge`` with ``noise_factor`` 0.

    Examples
    --------
    >>> from lanefinder.config import ThresholdConfig
    >>> rowwise(ThresholdConfig()), rowwise(ThresholdConfig.model_validate({"ridge": {"noise_factor": 0}}))
    (False, True)
    """
    return cfg.strategy == "ridge" and cfg.ridge.noise_factor == 0


def threshold(image: np.ndarray, cfg: ThresholdConfig, xm_per_px: float) -> np.ndarray:
    """Find lane-marking pixels with the configured strategy.

    Parameters
    ----------
    image : (H, W, 3) uint8 ndarray
        BGR image (the bird's-eye view, in the pipeline).
    cfg : ThresholdConfig
        ``strategy`` and each strategy's levels.
    xm_per_px : float
        Metres per pixel across the road: sizes the ``ridge`` window.

    Returns
    -------
    (H, W) uint8 ndarray
        1 on marking pixels, 0 elsewhere.

    Examples
    --------
    >>> from lanefinder.config import ThresholdConfig
    >>> img = np.full((20, 40, 3), 90, np.uint8); img[:, 18:22] = 220
    >>> int(threshold(img, ThresholdConfig(), 0.025).sum())
    80
    """
    func, section = STRATEGIES[cfg.strategy]
    if cfg.strategy == "ridge":
        return ridge(image, cfg.ridge, xm_per_px)
    return func(image, getattr(cfg, section))



def streaks(binary: np.ndarray, car_px: tuple[float, float], xm_per_px: float, ym_per_px: float,
            cfg: StreaksConfig) -> np.ndarray:
    """Find the set pixels of a bird's-eye binary that lie on streaks pointing at the camera.

    Anything upright in the frame (the reflection of a lamp on a wet road, a vehicle's side)
    lies, in the bird's-eye view, on a ray from the road point right below the camera.  The
    set pixels are binned by their direction from that point (fans ``cfg.bin_deg`` wide, twice,
    the second time shifted by half a fan); a fan whose pixels cover ``cfg.min_run_m`` of the
    road ahead or more, and that passes at least ``cfg.min_side_m`` to the side of the car at
    the view's bottom row, holds a streak.  A lane line crosses the fans: one that curves away
    from a ray stays in a fan for a few metres only.

    Parameters
    ----------
    binary : (H, W) uint8 ndarray
        The bird's-eye binary, 0/1.
    car_px : tuple of float
        Bird's-eye (x, y) of the road point right below the camera
        (:func:`lanefinder.birdseye.camera_foot_px`): y below the bottom row.
    xm_per_px, ym_per_px : float
        Metres per pixel across and along the road.
    cfg : StreaksConfig
        The fans and the lengths.

    Returns
    -------
    (H, W) bool ndarray
        True on the streaks' pixels (none where ``car_px`` is not below the view).

    Examples
    --------
    >>> from lanefinder.config import StreaksConfig
    >>> b = np.zeros((300, 400), np.uint8)
    >>> b[:, 122:127] = 1                      # a lane line, 1.9 m left of the car
    >>> y = np.arange(30, 300); b[y, np.round(200 - (y - 360) * 0.6).astype(int)] = 1  # a ray from the camera
    >>> s = streaks(b, (200.0, 360.0), 0.025, 0.1, StreaksConfig())
    >>> bool(s[:, 122:127].any()), int(s.sum())
    (False, 270)
    """
    h, w = binary.shape[:2]
    out = np.zeros((h, w), bool)
    cx, cy = car_px
    if not (math.isfinite(cx) and math.isfinite(cy)) or cy <= h:
        return out
    pts = cv2.findNonZero(binary)
    if pts is None:
        return out
    pts = pts.reshape(-1, 2)
    on = streak_points(pts[:, 0], pts[:, 1], (h, w), car_px, xm_per_px, ym_per_px, cfg)
    out[pts[on, 1], pts[on, 0]] = True
    return out


def streak_points(x: np.ndarray, y: np.ndarray, shape: tuple[int, int], car_px: tuple[float, float],
                  xm_per_px: float, ym_per_px: float, cfg: StreaksConfig) -> np.ndarray:
    """:func:`streaks` for a binary's set pixels given as columns and rows: which lie on streaks.

    Parameters
    ----------
    x, y : ndarray
        Columns and rows of the set pixels (as :class:`lanefinder.search.Pixels` holds them).
    shape : tuple of int
        (height, width) of the binary.
    car_px, xm_per_px, ym_per_px, cfg
        As for :func:`streaks`.

    Returns
    -------
    ndarray of bool
        Per pixel given, True on a streak.

    Examples
    --------
    >>> from lanefinder.config import StreaksConfig
    >>> y = np.arange(30, 300); x = np.round(200 - (y - 360) * 0.6).astype(int)  # a ray from the camera
    >>> int(streak_points(x, y, (300, 400), (200.0, 360.0), 0.025, 0.1, StreaksConfig()).sum())
    270
    """
    h, w = shape
    cx, cy = car_px
    none = np.zeros(np.shape(x), bool)
    if x.size == 0 or not (math.isfinite(cx) and math.isfinite(cy)) or cy <= h:
        return none
    behind_m = (cy - h) * ym_per_px
    # The tangent of each pixel's direction from the car, and the fans that can hold a streak:
    # to the side of the car at the bottom row, and narrow enough to stay in the view along min_run_m.
    tan = (x - cx) * xm_per_px / ((cy - y) * ym_per_px)
    widest = max(cx, w - 1 - cx) * xm_per_px / (behind_m + cfg.min_run_m)
    narrowest = cfg.min_side_m / behind_m if behind_m > 0 else math.inf
    cand = np.flatnonzero((np.abs(tan) >= narrowest) & (np.abs(tan) <= widest))
    if cand.size == 0:
        return none
    theta = np.arctan(tan[cand])
    ys = y[cand]
    step = math.radians(cfg.bin_deg)
    flagged = np.zeros(cand.size, bool)
    for shift in (0.0, 0.5):
        fan = np.floor(theta / step + shift).astype(np.int64)
        fan -= fan.min()
        rows = np.zeros((int(fan.max()) + 1) * h, bool)
        rows[fan * h + ys] = True  # the rows each fan has pixels on
        run_m = np.count_nonzero(rows.reshape(-1, h), axis=1) * ym_per_px
        flagged |= run_m[fan] >= cfg.min_run_m
    none[cand[flagged]] = True
    return none

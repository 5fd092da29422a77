"""Camera model: chessboard calibration, lens distortion, and camera files.

A :class:`CameraModel` holds the intrinsic matrix ``K`` (pixels), the OpenCV
distortion coefficients and the frame size it was made for.  Frames of the same
aspect ratio at another size are served by :meth:`CameraModel.scaled_to`.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from functools import cache
from importlib import resources
from pathlib import Path
from typing import Literal

import cv2
import numpy as np

from .config import MAX_FOV_DEG, MIN_FOV_DEG, field_of_view_deg
from .errors import LaneFinderError
from .io import atomic_write_text, list_images, read_image

__all__ = [
    "CameraModel",
    "ViewReport",
    "board_points",
    "board_visible",
    "calibrate",
    "calibration_photos",
    "distort_points",
    "find_board",
    "load_camera",
    "save_camera",
    "udacity_camera",
    "undistort_points",
]

# Sizes are (width, height) in pixels throughout.
Size = tuple[int, int]

_CORNER_FLAGS = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE | cv2.CALIB_CB_FAST_CHECK
_SUBPIX_CRITERIA = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 50, 1e-3)
_ASPECT_TOLERANCE = 0.01
#: Photos at least this high and wide get a first quick look halved (see :func:`board_visible`).
_HALVED_LOOK_MIN_PX = 480


@dataclass(frozen=True, eq=False)
class CameraModel:
    """Pinhole camera with OpenCV lens distortion.

    Attributes
    ----------
    camera_matrix : (3, 3) float64 ndarray
        Intrinsics K, pixels.
    dist_coeffs : (N,) float64 ndarray
        OpenCV distortion coefficients (k1, k2, p1, p2, k3, ...).
    image_size : tuple of int
        (width, height) of the frames K refers to, pixels.
    rms_px : float or None
        RMS reprojection error of the calibration, pixels, if known.
    board : tuple of int or None
        The chessboard's inner corners (cols, rows) it was calibrated with, if any.
    views : tuple of ViewReport
        One report per calibration photo.
    source : str
        Where the model came from (a file, ``calibration``, ``ideal ...``).

    Examples
    --------
    >>> cam = CameraModel.ideal((1280, 720), hfov_deg=60.0)
    >>> round(float(cam.camera_matrix[0, 0]), 1), cam.has_distortion
    (1108.5, False)
    >>> cam.scaled_to((640, 360)).image_size
    (640, 360)
    """

    camera_matrix: np.ndarray
    dist_coeffs: np.ndarray
    image_size: Size
    rms_px: float | None = None
    board: tuple[int, int] | None = None
    views: tuple[ViewReport, ...] = field(default_factory=tuple)
    source: str = ""

    @property
    def has_distortion(self) -> bool:
        """True when any distortion coefficient is non-zero."""
        return bool(np.any(self.dist_coeffs != 0))

    @classmethod
    def ideal(cls, image_size: Size, hfov_deg: float = 60.0, focal_px: float | None = None) -> CameraModel:
        """Make a distortion-free camera: for footage with no calibration.

        Parameters
        ----------
        image_size : tuple of int
            (width, height), pixels.
        hfov_deg : float, optional
            Horizontal field of view, degrees.
        focal_px : float, optional
            The focal length, pixels (instead of ``hfov_deg``).

        Returns
        -------
        CameraModel
            Principal point at the image centre, square pixels, no distortion.
        """
        w, h = image_size
        f = focal_px if focal_px is not None else (w / 2) / math.tan(math.radians(hfov_deg) / 2)
        k = np.array([[f, 0, (w - 1) / 2], [0, f, (h - 1) / 2], [0, 0, 1]], dtype=np.float64)
        return cls(k, np.zeros(5), (int(w), int(h)), source="ideal (no distortion model)")

    def scaled_to(self, image_size: Size) -> CameraModel:
        """Give the same camera for frames of another size with the same aspect ratio.

        Parameters
        ----------
        image_size : tuple of int
            (width, height) of the frames, pixels.

        Returns
        -------
        CameraModel
            K scaled about pixel centres; the same object when the size is unchanged.

        Raises
        ------
        LaneFinderError
            When the aspect ratio differs by more than 1%.
        """
        w, h = (int(v) for v in image_size)
        w0, h0 = self.image_size
        if (w, h) == (w0, h0):
            return self
        if abs((w / h) / (w0 / h0) - 1) > _ASPECT_TOLERANCE:
            raise LaneFinderError(
                f"frame size {w}x{h} does not match the camera ({w0}x{h0}): the aspect ratio differs, "
                "so the calibration cannot be scaled; calibrate this camera at this size"
            )
        sx, sy = w / w0, h / h0
        k = self.camera_matrix.copy()
        # Pixel centres: a pixel index i covers [i, i+1), so centres scale as (c + 0.5) * s - 0.5.
        k[0, 0] *= sx
        k[1, 1] *= sy
        k[0, 2] = (k[0, 2] + 0.5) * sx - 0.5
        k[1, 2] = (k[1, 2] + 0.5) * sy - 0.5
        return CameraModel(k, self.dist_coeffs.copy(), (w, h), self.rms_px, self.board, self.views, self.source)

    def undistort(self, image: np.ndarray) -> np.ndarray:
        """Return an undistorted copy of ``image`` (same K); for figures, not the per-frame path.

        Parameters
        ----------
        image : (H, W[, C]) ndarray
            A frame with this camera's aspect ratio.

        Returns
        -------
        ndarray
            The undistorted frame, same size.
        """
        cam = self.scaled_to((image.shape[1], image.shape[0]))
        return cv2.undistort(image, cam.camera_matrix, cam.dist_coeffs)

    def to_dict(self) -> dict:
        """Give the camera as plain JSON-ready values (see :func:`save_camera`).

        Returns
        -------
        dict
            ``image_size``, ``camera_matrix``, ``dist_coeffs``, ``rms_px``, ``board``, ``views``.
        """
        return {
            "image_size": list(self.image_size),
            "camera_matrix": self.camera_matrix.tolist(),
            "dist_coeffs": self.dist_coeffs.ravel().tolist(),
            "rms_px": self.rms_px,
            "board": list(self.board) if self.board else None,
            "views": [v.to_dict() for v in self.views],
        }


@dataclass(frozen=True)
class ViewReport:
    """One calibration photo: what was found and how well it fits.

    Attributes
    ----------
    path : str
        The photo.
    used : bool
        Whether it took part in the calibration.
    reason : str
        Why not, or a note (cropped, partial board).
    pattern : tuple of int or None
        The inner corners (cols, rows) found.
    error_px : float or None
        RMS reprojection error of this photo's corners, pixels.

    Examples
    --------
    >>> ViewReport(path="c1.jpg", used=False, reason="no chessboard found").to_dict()["reason"]
    'no chessboard found'
    """

    path: str
    used: bool
    reason: str = ""
    pattern: tuple[int, int] | None = None
    error_px: float | None = None

    def to_dict(self) -> dict:
        """Give the report as plain JSON-ready values.

        Returns
        -------
        dict
            ``path``, ``used``, ``reason``, ``pattern``, ``error_px``.
        """
        return {
            "path": self.path,
            "used": self.used,
            "reason": self.reason,
            "pattern": list(self.pattern) if self.pattern else None,
            "error_px": self.error_px,
        }


def _sub_board_sizes(board: tuple[int, int], min_corners: int = 12) -> list[tuple[int, int]]:
    """Board sizes to try, largest first: the full board, then sub-boards."""
    cols, rows = board
    sizes = [(c, r) for c in range(cols, 2, -1) for r in range(rows, 2, -1) if c * r >= min_corners]
    return sorted(sizes, key=lambda s: (-s[0] * s[1], -s[0]))


def board_visible(gray: np.ndarray) -> bool:
    """Tell quickly whether a photo shows any chessboard at all (3x3 inner corners or more).

    The sector-based detector (``cv2.findChessboardCornersSB``) takes 100-150 ms on a 720p
    photo with or without a board (measured on this project's 2-core machine), where the
    classic search of :func:`find_board` spends about 4.5 s trying every sub-board of a photo
    that has none.  It looks at the photo halved first (about 35 ms), and at the whole photo
    only when the halved one shows no board: a board seen at either scale counts.  On the 20
    Udacity calibration photos and the 8 road photos the halved look decides as the whole
    photo does (``tests/test_camera.py`` checks it).

    Parameters
    ----------
    gray : (H, W) uint8 ndarray
        The photo, grey.

    Returns
    -------
    bool
        False when no chessboard corners form a grid.

    Examples
    --------
    >>> board_visible(np.full((240, 320), 128, np.uint8))
    False
    """
    if min(gray.shape[:2]) >= _HALVED_LOOK_MIN_PX:
        half = cv2.resize(gray, None, fx=0.5, fy=0.5, interpolation=cv2.INTER_AREA)
        if cv2.findChessboardCornersSBWithMeta(half, (3, 3), cv2.CALIB_CB_LARGER)[0]:
            return True
    ok, _, _ = cv2.findChessboardCornersSBWithMeta(gray, (3, 3), cv2.CALIB_CB_LARGER)
    return bool(ok)


def find_board(gray: np.ndarray, board: tuple[int, int],
               sizes: Literal["all", "whole", "partial"] = "all") -> tuple[np.ndarray, tuple[int, int]] | None:
    """Find the largest visible (sub-)board of a chessboard's inner corners.

    Parameters
    ----------
    gray : (H, W) uint8 ndarray
        The photo, grey.
    board : tuple of int
        The full board's inner corners, (cols, rows).
    sizes : {"all", "whole", "partial"}, optional
        Look for the whole board and then its sub-boards, the whole board only, or the
        sub-boards only.

    Returns
    -------
    tuple or None
        (corners, pattern): corners (N, 1, 2) float32 refined to subpixel, pattern the
        (cols, rows) found, the full board or the largest sub-board with at least 12
        corners; None when :func:`board_visible` sees no board or no pattern is found.

    Examples
    --------
    >>> import cv2
    >>> corners, pattern = find_board(cv2.imread("data/camera_cal/calibration2.jpg", 0), (9, 6))
    >>> corners.shape, pattern
    ((54, 1, 2), (9, 6))
    """
    if not board_visible(gray):
        return None
    patterns = _sub_board_sizes(board)
    patterns = patterns[:1] if sizes == "whole" else patterns[1:] if sizes == "partial" else patterns
    for pattern in patterns:
        ok, corners = cv2.findChessboardCorners(gray, pattern, _CORNER_FLAGS)
        if ok:
            corners = cv2.cornerSubPix(gray, corners, (11, 11), (-1, -1), _SUBPIX_CRITERIA)
            return corners.reshape(-1, 1, 2), pattern
    return None


def board_points(pattern: tuple[int, int], square: float = 1.0) -> np.ndarray:
    """Give the object points of a grid of corners on the z=0 plane.

    Parameters
    ----------
    pattern : tuple of int
        (cols, rows) of inner corners.
    square : float, optional
        The square's side, in any unit (the calibration's K does not depend on it).

    Returns
    -------
    (cols*rows, 3) float32 ndarray
        Row by row, in the order ``cv2.findChessboardCorners`` gives the corners.

    Examples
    --------
    >>> board_points((3, 2))[:4].tolist()
    [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
    """
    cols, rows = pattern
    grid = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2).astype(np.float32) * square
    return np.hstack([grid, np.zeros((len(grid), 1), np.float32)])


def calibrate(
    photos: Sequence[str | Path],
    board: tuple[int, int] = (9, 6),
    image_size: Size | None = None,
) -> CameraModel:
    """Calibrate a camera from chessboard photos.

    Photos whose full board is cut off count through their largest visible sub-board,
    each with its own object points.  Photos up to 2 px larger than ``image_size``
    are cropped at the right/bottom edge, which keeps the principal point; other sizes
    are skipped and reported.

    Parameters
    ----------
    photos : sequence of str or Path
        The photos, all from the one camera at one zoom.
    board : tuple of int, optional
        The board's inner corners, (cols, rows).
    image_size : tuple of int, optional
        (width, height) to calibrate at; default the most common photo size.

    Returns
    -------
    CameraModel
        K, distortion, RMS reprojection error (pixels) and a report per photo.

    Raises
    ------
    LaneFinderError
        When no photos are given, one cannot be read, or fewer than 3 show the whole board.

    Examples
    --------
    >>> from lanefinder.io import list_images
    >>> cam = calibrate(list_images(["data/camera_cal"]))  # doctest: +SKIP
    >>> round(cam.rms_px, 2)  # doctest: +SKIP
    0.996
    >>> calibrate(["data/test_images/test1.jpg"])
    Traceback (most recent call last):
    ...
    lanefinder.errors.LaneFinderError: no 9x6 chessboard was found in any of the 1 photos
    """
    if not photos:
        raise LaneFinderError("no calibration photos given")
    images = [(str(p), read_image(p)) for p in photos]
    if image_size is None:
        sizes = [(im.shape[1], im.shape[0]) for _, im in images]
        image_size = max(set(sizes), key=lambda s: (sizes.count(s), -s[0]))
    w, h = image_size

    # Each photo at the calibration size (or its reason for being skipped), grey.
    grays: list[tuple[str, np.ndarray | None, str]] = []
    for path, im in images:
        ih, iw = im.shape[:2]
        note = ""
        if (iw, ih) != (w, h):
            if not (w <= iw <= w + 2 and h <= ih <= h + 2):
                grays.append((path, None, f"size {iw}x{ih} differs from {w}x{h}"))
                continue
            im = im[:h, :w]
            note = f"cropped {iw}x{ih} to {w}x{h}"
        grays.append((path, cv2.cvtColor(im, cv2.COLOR_BGR2GRAY) if im.ndim == 3 else im, note))
    # The whole board first, in every photo: too few whole boards ends the work early (a wrong
    # --board would otherwise try every sub-board of every photo).
    found = [find_board(g, board, "whole") if g is not None else None for _, g, _ in grays]
    whole = sum(f is not None for f in found)
    if whole == 0:
        raise LaneFinderError(f"no {board[0]}x{board[1]} chessboard was found in any of the {len(images)} photos")
    if whole < 3:
        raise LaneFinderError(
            f"only {whole} photo(s) show the whole {board[0]}x{board[1]} board; at least 3 are needed (partial "
            "boards are used only beside them): is --board the board's inner corners?")
    found = [f if f is not None or g is None else find_board(g, board, "partial")
             for f, (_, g, _) in zip(found, grays, strict=True)]

    obj_pts, img_pts, reports, used_idx = [], [], [], []
    for (path, gray, note), f in zip(grays, found, strict=True):
        if gray is None or f is None:
            reports.append(ViewReport(path, False, note if gray is None else "no chessboard found"))
            continue
        corners, pattern = f
        if pattern != board:
            note = "; ".join(filter(None, [note, f"partial board {pattern[0]}x{pattern[1]}"]))
        obj_pts.append(board_points(pattern))
        img_pts.append(corners)
        used_idx.append(len(reports))
        reports.append(ViewReport(path, True, note, pattern))

    rms, k, dist, rvecs, tvecs = cv2.calibrateCamera(obj_pts, img_pts, (w, h), None, None)
    for i, (obj, img, rv, tv) in enumerate(zip(obj_pts, img_pts, rvecs, tvecs, strict=True)):
        proj, _ = cv2.projectPoints(obj, rv, tv, k, dist)
        err = float(np.sqrt(np.mean(np.sum((proj.reshape(-1, 2) - img.reshape(-1, 2)) ** 2, axis=1))))
        r = reports[used_idx[i]]
        reports[used_idx[i]] = ViewReport(r.path, True, r.reason, r.pattern, err)
    return CameraModel(k, dist.ravel(), (w, h), float(rms), tuple(board), tuple(reports), "calibration")


def save_camera(camera: CameraModel, path: str | Path) -> None:
    """Write the camera as JSON (K, distortion, size, RMS, board, per-view errors).

    Parameters
    ----------
    camera : CameraModel
        The camera.
    path : str or Path
        The JSON file, written atomically.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "cam.json"
    >>> save_camera(udacity_camera(), out)
    >>> load_camera(out).image_size
    (1280, 720)
    """
    atomic_write_text(path, json.dumps(camera.to_dict(), indent=2) + "\n")


def load_camera(path: str | Path) -> CameraModel:
    """Read a camera file: our JSON, or the YAML/XML that OpenCV's calibration sample writes.

    Parameters
    ----------
    path : str or Path
        A ``.json`` from :func:`save_camera`, or an OpenCV FileStorage file with
        ``camera_matrix``, ``distortion_coefficients``, ``image_width`` and ``image_height``.

    Returns
    -------
    CameraModel
        The camera; ``source`` is the path.

    Raises
    ------
    LaneFinderError
        When the file is missing or is not a camera file.

    Examples
    --------
    >>> load_camera("nowhere.json")
    Traceback (most recent call last):
    ...
    lanefinder.errors.LaneFinderError: camera file not found: nowhere.json
    """
    p = Path(path)
    if p.is_dir():
        raise LaneFinderError(f"{p} is a folder, not a camera file")
    if not p.is_file():
        hint = f" (camera.model {p.name.lower()!r} is lower case)" if p.name.lower() in ("none", "udacity") else ""
        raise LaneFinderError(f"camera file not found: {p}{hint}")
    if p.suffix.lower() == ".json" or _looks_like_json(p):
        try:
            d = json.loads(p.read_text())
            if isinstance(d, dict) and isinstance(d.get("camera_matrix"), dict):  # OpenCV's FileStorage JSON
                return _load_opencv_storage(p)
            k = np.asarray(d["camera_matrix"], dtype=np.float64).reshape(3, 3)
            dist = np.asarray(d["dist_coeffs"], dtype=np.float64).ravel()
            size = tuple(int(v) for v in d["image_size"])
            views = tuple(
                ViewReport(str(v["path"]), bool(v["used"]), str(v.get("reason", "")),
                           tuple(v["pattern"]) if v.get("pattern") else None, v.get("error_px"))
                for v in d.get("views", [])
            )
            board = tuple(int(v) for v in d["board"]) if d.get("board") else None
        except (ValueError, KeyError, TypeError, AttributeError, UnicodeDecodeError) as e:
            raise LaneFinderError(f"{p}: not a lanefinder camera file ({e})") from None
        return _checked_camera(p, k, dist, size, d.get("rms_px"), board, views)
    return _load_opencv_storage(p)


def _looks_like_json(p: Path) -> bool:
    """Tell whether a camera file of another name holds a JSON object (ours renamed, or OpenCV's JSON)."""
    try:
        with open(p, "rb") as f:
            return f.read(64).lstrip().startswith(b"{")
    except OSError:
        return False


def _checked_camera(p: Path, k: np.ndarray, dist: np.ndarray, size: tuple, rms, board=None, views=(),
                    ) -> CameraModel:
    """Refuse a camera file whose numbers cannot describe a camera, naming what is wrong."""
    if k.shape != (3, 3) or not np.all(np.isfinite(k)):
        raise LaneFinderError(f"{p}: camera_matrix must be 3x3 finite numbers")
    if not (k[0, 0] > 0 and k[1, 1] > 0 and np.allclose(k[2], [0, 0, 1]) and k[1, 0] == 0):
        raise LaneFinderError(f"{p}: camera_matrix is not a camera's (focal lengths must be positive, "
                              "the last row 0 0 1)")
    if dist.size not in (4, 5, 8, 12, 14) or not np.all(np.isfinite(dist)):
        raise LaneFinderError(f"{p}: dist_coeffs must be 4, 5, 8, 12 or 14 finite numbers")
    if len(size) != 2 or not all(16 <= v <= 16384 for v in size):
        raise LaneFinderError(f"{p}: image_size must be (width, height), 16 to 16384 pixels each")
    fov = field_of_view_deg(k[0, 0], size[0])
    if not MIN_FOV_DEG <= fov <= MAX_FOV_DEG:
        raise LaneFinderError(f"{p}: a focal length of {k[0, 0]:g} px over {size[0]} px is a {fov:.2f} degree field "
                              f"of view: lanefinder takes {MIN_FOV_DEG:g} to {MAX_FOV_DEG:g}")
    _check_distortion(p, k, dist, (int(size[0]), int(size[1])))
    if rms is not None and not (isinstance(rms, (int, float)) and math.isfinite(rms)):
        raise LaneFinderError(f"{p}: rms_px must be a number")
    return CameraModel(k, dist, (int(size[0]), int(size[1])), rms, board, views, str(p))


#: A lens may bend the frame's corners at most this many times nearer to or farther from its
#: centre than a pinhole would put them (fisheye-like dashcams: 1.5-2.5).
MAX_DISTORTION_RATIO = 5.0


def _check_distortion(p: Path, k: np.ndarray, dist: np.ndarray, size: tuple[int, int]) -> None:
    """Refuse distortion coefficients that fold the frame or shrink it to a point (not a lens)."""
    w, h = size
    corners = np.array([[0, 0], [w - 1, 0], [0, h - 1], [w - 1, h - 1], [w - 1, (h - 1) / 2]], np.float64)
    bad = f"{p}: dist_coeffs do not describe a lens over a {w}x{h} frame"
    with np.errstate(all="ignore"):
        und = cv2.undistortPoints(corners.reshape(-1, 1, 2), k, dist, R=None, P=None,  # normalised pinhole rays
                                  criteria=(cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-9)).reshape(-1, 2)
        back = cv2.projectPoints(np.column_stack([und, np.ones(len(und))]), np.zeros(3), np.zeros(3), k,
                                 dist)[0].reshape(-1, 2)
        r_d = np.hypot((corners[:, 0] - k[0, 2]) / k[0, 0], (corners[:, 1] - k[1, 2]) / k[1, 1])
        ratio = np.hypot(und[:, 0], und[:, 1]) / np.maximum(r_d, 1e-12)
    if not (np.all(np.isfinite(back)) and np.all(np.isfinite(ratio))):
        raise LaneFinderError(bad + " (they give no finite undistortion)")
    if np.abs(back - corners).max() > 2.0:
        raise LaneFinderError(bad + " (they fold it: the undistortion of its corners does not map back)")
    if not (ratio.min() >= 1 / MAX_DISTORTION_RATIO and ratio.max() <= MAX_DISTORTION_RATIO):
        raise LaneFinderError(bad + f" (they move its corners {max(ratio.max(), 1 / ratio.min()):.3g} times "
                              f"nearer or farther than a pinhole would; at most {MAX_DISTORTION_RATIO:g})")


def _load_opencv_storage(p: Path) -> CameraModel:
    try:
        fs = cv2.FileStorage(str(p), cv2.FILE_STORAGE_READ)
    except (cv2.error, SystemError, UnicodeDecodeError):
        raise LaneFinderError(f"{p}: cannot read it as JSON or as OpenCV YAML/XML") from None
    try:
        if not fs.isOpened():
            raise LaneFinderError(f"{p}: cannot read it as JSON or as OpenCV YAML/XML")
        k = fs.getNode("camera_matrix").mat()
        dist = fs.getNode("distortion_coefficients").mat()
        w, h = fs.getNode("image_width").real(), fs.getNode("image_height").real()
        rms_node = fs.getNode("avg_reprojection_error")
        rms = rms_node.real() if not rms_node.empty() else None
    except cv2.error:  # a node that is not what its name says (text where a matrix should be)
        raise LaneFinderError(f"{p}: an OpenCV camera file needs camera_matrix, distortion_coefficients, "
                              "image_width and image_height") from None
    finally:
        fs.release()
    if k is None or k.shape != (3, 3) or dist is None or not w or not h:
        raise LaneFinderError(
            f"{p}: an OpenCV camera file needs camera_matrix, distortion_coefficients, image_width and image_height"
        )
    return _checked_camera(p, k.astype(np.float64), dist.astype(np.float64).ravel(), (w, h), rms)


def calibration_photos(inputs: Iterable[str | Path]) -> list[Path]:
    """Expand files and folders into a list of calibration photos.

    Parameters
    ----------
    inputs : iterable of str or Path
        Photos and folders of photos.

    Returns
    -------
    list of Path
        As :func:`lanefinder.io.list_images`: folders sorted naturally.

    Examples
    --------
    >>> len(calibration_photos(["data/camera_cal"]))
    20
    """
    return list_images(inputs, what="calibration photos")


def undistort_points(camera: CameraModel, points: np.ndarray) -> np.ndarray:
    """Map distorted pixels to undistorted pixels (same K).

    Parameters
    ----------
    camera : CameraModel
        The lens model.
    points : (N, 2) array_like
        Distorted (x, y) pixels.

    Returns
    -------
    (N, 2) float64 ndarray
        Undistorted (x, y) pixels.

    Examples
    --------
    >>> cam = udacity_camera()
    >>> p = np.array([[400.0, 500.0]])
    >>> bool(np.allclose(distort_points(cam, undistort_points(cam, p)), p, atol=1e-3))
    True
    """
    pts = np.asarray(points, np.float64).reshape(-1, 1, 2)
    out = cv2.undistortPoints(pts, camera.camera_matrix, camera.dist_coeffs, P=camera.camera_matrix)
    return out.reshape(-1, 2)


def distort_points(camera: CameraModel, points: np.ndarray) -> np.ndarray:
    """Map undistorted pixels to distorted pixels: the exact forward lens model.

    Parameters
    ----------
    camera : CameraModel
        The lens model.
    points : (N, 2) array_like
        Undistorted (x, y) pixels.

    Returns
    -------
    (N, 2) float64 ndarray
        Distorted (x, y) pixels.

    Examples
    --------
    >>> cam = CameraModel.ideal((1280, 720))
    >>> distort_points(cam, [[10.0, 20.0]]).tolist()
    [[10.0, 20.0]]
    """
    pts = np.asarray(points, np.float64).reshape(-1, 2)
    if len(pts) == 0:
        return pts
    k = camera.camera_matrix
    x = (pts[:, 0] - k[0, 2]) / k[0, 0]
    y = (pts[:, 1] - k[1, 2]) / k[1, 1]
    d = np.asarray(camera.dist_coeffs, np.float64).ravel()
    if d.size > 8 and np.any(d[8:]):  # thin-prism or tilted models: OpenCV's own projection
        rays = np.column_stack([x, y, np.ones(len(pts))])
        out, _ = cv2.projectPoints(rays, np.zeros(3), np.zeros(3), k, d)
        return out.reshape(-1, 2)
    # OpenCV's rational model (k1, k2, p1, p2[, k3[, k4, k5, k6]]), in NumPy: the same numbers
    # as cv2.projectPoints, a tenth of its cost on the few points a frame maps.
    k1, k2, p1, p2, k3, k4, k5, k6 = np.concatenate([d[:8], np.zeros(max(0, 8 - d.size))])
    r2 = x * x + y * y
    radial = (1 + r2 * (k1 + r2 * (k2 + r2 * k3))) / (1 + r2 * (k4 + r2 * (k5 + r2 * k6)))
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    return np.column_stack([k[0, 0] * xd + k[0, 1] * yd + k[0, 2], k[1, 1] * yd + k[1, 2]])


@cache
def udacity_camera() -> CameraModel:
    """Give the built-in camera: the calibration of the Udacity chessboard photos.

    Returns
    -------
    CameraModel
        K and distortion of the Udacity dashcam at 1280x720 (RMS 0.996 px).

    Examples
    --------
    >>> cam = udacity_camera()
    >>> cam.image_size
    (1280, 720)
    """
    path = resources.files("lanefinder") / "data" / "udacity_camera.json"
    with resources.as_file(path) as p:
        return load_camera(p)

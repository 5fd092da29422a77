"""Bird's-eye view: one remap from the distorted frame to a top-down view of the road.

Coordinates: frame and bird's-eye pixels are (x, y), origin top-left.  In the
bird's-eye image the car is at the bottom row and y grows towards the car.

The homography ``M`` maps *undistorted* frame pixels to bird's-eye pixels.  The
remap tables combine lens undistortion with ``M``, so a single ``cv2.remap``
takes the raw frame straight to the bird's-eye image.  Points go back onto the
raw (distorted) frame exactly: inverse homography, then the forward lens model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from .camera import CameraModel, distort_points, undistort_points

__all__ = ["BirdsEye", "camera_foot_px", "make_birdseye", "plane_pose", "setup_of", "src_vanishing_point"]


@dataclass(frozen=True, eq=False)
class BirdsEye:
    """A bird's-eye set-up for one camera at one frame size; build it with :func:`make_birdseye`.

    Attributes
    ----------
    camera : CameraModel
        The lens model; ``camera.image_size`` is the frame size this set-up takes.
    src_px : (4, 2) float32 ndarray
        The road trapezoid in undistorted frame pixels.
    dst_px : (4, 2) float32 ndarray
        Where it lands: a rectangle in bird's-eye pixels.
    size : tuple of int
        (width, height) of the bird's-eye image, pixels.
    xm_per_px, ym_per_px : float
        Metres per bird's-eye pixel across and along the road.
    matrix, matrix_inv : (3, 3) ndarray
        The homography from undistorted frame pixels to bird's-eye pixels, and its inverse.
    map1, map2 : ndarray
        The ``cv2.remap`` tables from the raw frame to the bird's-eye image.
    car_x_px : float
        Bird's-eye x of the road point right below the camera (see :func:`camera_foot_px`).
    car_y_px : float
        Its bird's-eye y: below the bottom row, the camera being behind the view (NaN: unknown).

    Examples
    --------
    >>> from lanefinder import LaneFinder
    >>> be = LaneFinder().birdseye((1280, 720))
    >>> be.size, round(be.xm_per_px, 4)
    ((400, 300), 0.0247)
    """

    camera: CameraModel
    src_px: np.ndarray
    dst_px: np.ndarray
    size: tuple[int, int]
    xm_per_px: float
    ym_per_px: float
    matrix: np.ndarray
    matrix_inv: np.ndarray
    map1: np.ndarray
    map2: np.ndarray
    car_x_px: float
    car_y_px: float = float("nan")

    @property
    def frame_size(self) -> tuple[int, int]:
        """(width, height) of the raw frames this set-up takes, pixels."""
        return self.camera.image_size

    def warp(self, frame: np.ndarray, interpolation: int = cv2.INTER_LINEAR) -> np.ndarray:
        """Map a raw (distorted) frame to the bird's-eye image, in one remap.

        Parameters
        ----------
        frame : (H, W[, C]) ndarray
            A raw frame of ``frame_size``.
        interpolation : int, optional
            An OpenCV interpolation flag.

        Returns
        -------
        ndarray
            The bird's-eye image, ``size`` pixels, same dtype and channels.
        """
        # Outside the frame is black (a constant border is cheaper than a replicated one, and a
        # wide dark area is no marking: the ridge test needs road on both sides).
        return cv2.remap(frame, self.map1, self.map2, interpolation)

    def warp_undistorted(self, image: np.ndarray) -> np.ndarray:
        """Map an already undistorted frame to the bird's-eye image (for figures).

        Parameters
        ----------
        image : ndarray
            An undistorted frame of ``frame_size``.

        Returns
        -------
        ndarray
            The bird's-eye image, ``size`` pixels.
        """
        return cv2.warpPerspective(image, self.matrix, self.size, flags=cv2.INTER_LINEAR)

    def to_frame(self, points: np.ndarray) -> np.ndarray:
        """Map bird's-eye pixels to raw frame pixels, the exact inverse of :meth:`warp`.

        Parameters
        ----------
        points : (N, 2) array_like
            Bird's-eye (x, y) pixels.

        Returns
        -------
        (N, 2) float64 ndarray
            Raw (distorted) frame (x, y) pixels.
        """
        undist = cv2.perspectiveTransform(np.asarray(points, np.float64).reshape(-1, 1, 2), self.matrix_inv)
        return distort_points(self.camera, undist.reshape(-1, 2))

    def to_undistorted(self, points: np.ndarray) -> np.ndarray:
        """Map bird's-eye pixels to undistorted frame pixels.

        Parameters
        ----------
        points : (N, 2) array_like
            Bird's-eye (x, y) pixels.

        Returns
        -------
        (N, 2) float64 ndarray
            Undistorted frame (x, y) pixels.
        """
        pts = np.asarray(points, np.float64).reshape(-1, 1, 2)
        return cv2.perspectiveTransform(pts, self.matrix_inv).reshape(-1, 2)

    def from_frame(self, points: np.ndarray) -> np.ndarray:
        """Map raw frame pixels to bird's-eye pixels.

        Parameters
        ----------
        points : (N, 2) array_like
            Raw (distorted) frame (x, y) pixels.

        Returns
        -------
        (N, 2) float64 ndarray
            Bird's-eye (x, y) pixels.
        """
        undist = undistort_points(self.camera, points)
        return cv2.perspectiveTransform(undist.reshape(-1, 1, 2), self.matrix).reshape(-1, 2)


def plane_pose(camera_matrix: np.ndarray, matrix: np.ndarray, xm_per_px: float,
               ym_per_px: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Recover the road plane seen by the camera from the bird's-eye set-up.

    A road point at metric bird's-eye coordinates (X, Y) = (u*xm, v*ym) images at
    K [r1 r2 t] (X, Y, 1).

    Parameters
    ----------
    camera_matrix : (3, 3) ndarray
        The camera's K.
    matrix : (3, 3) ndarray
        Homography from undistorted frame pixels to bird's-eye pixels.
    xm_per_px, ym_per_px : float
        Metres per bird's-eye pixel across and along the road.

    Returns
    -------
    r1, r2 : (3,) ndarray
        Unit directions of the bird's-eye x and y axes in the camera frame.
    t : (3,) ndarray
        The bird's-eye origin in the camera frame, metres.
    ratio : float
        |r1|/|r2| before normalising: 1.0 when ``xm_per_px`` and ``ym_per_px`` agree with
        the camera.

    Examples
    --------
    >>> from lanefinder import LaneFinder
    >>> be = LaneFinder().birdseye((1280, 720))
    >>> r1, r2, t, ratio = plane_pose(be.camera.camera_matrix, be.matrix, be.xm_per_px, be.ym_per_px)
    >>> round(float(np.linalg.norm(r1)), 6), bool(t[2] > 0)
    (1.0, True)
    """
    b = np.linalg.inv(camera_matrix) @ np.linalg.inv(matrix) @ np.diag([1.0 / xm_per_px, 1.0 / ym_per_px, 1.0])
    b = b * (1.0 if b[2, 2] >= 0 else -1.0)  # the homogeneous sign that puts the road in front
    n1, n2 = np.linalg.norm(b[:, 0]), np.linalg.norm(b[:, 1])
    return b[:, 0] / n1, b[:, 1] / n2, b[:, 2] / np.sqrt(n1 * n2), float(n1 / n2)


def camera_foot_px(camera_matrix: np.ndarray, matrix: np.ndarray, xm_per_px: float,
                   ym_per_px: float) -> tuple[float, float]:
    """Find the bird's-eye (x, y) of the road point right below the camera: the car's position.

    Its x is the camera's lateral place, which the offset is measured from; it allows for the
    camera's yaw and principal point, unlike "the image's centre column".

    Parameters
    ----------
    camera_matrix : (3, 3) ndarray
        The camera's K.
    matrix : (3, 3) ndarray
        Homography from undistorted frame pixels to bird's-eye pixels.
    xm_per_px, ym_per_px : float
        Metres per bird's-eye pixel across and along the road.

    Returns
    -------
    x_px, y_px : float
        Bird's-eye pixels (y beyond the bottom row: the camera is behind the view).

    Examples
    --------
    >>> from lanefinder import LaneFinder
    >>> be = LaneFinder().birdseye((1280, 720))
    >>> x, y = camera_foot_px(be.camera.camera_matrix, be.matrix, be.xm_per_px, be.ym_per_px)
    >>> round(x) == round(be.car_x_px), y > be.size[1]
    (True, True)
    """
    r1, r2, t, _ = plane_pose(camera_matrix, matrix, xm_per_px, ym_per_px)
    # The bird's-eye axes need not be orthogonal on the road (rows of the frame run square to
    # the camera axis, columns along the lane), so solve for the nearest road point in their basis.
    gram = np.array([[r1 @ r1, r1 @ r2], [r1 @ r2, r2 @ r2]])
    x_m, y_m = np.linalg.solve(gram, -np.array([t @ r1, t @ r2]))
    return float(x_m / xm_per_px), float(y_m / ym_per_px)


def src_vanishing_point(src_px: np.ndarray) -> tuple[float, float]:
    """Give where the sides of a road trapezoid meet: the vanishing point of the lane lines.

    Parameters
    ----------
    src_px : (4, 2) array_like
        Top-left, top-right, bottom-right, bottom-left, pixels.

    Returns
    -------
    x, y : float
        Pixels (NaN for parallel sides).

    Examples
    --------
    >>> src_vanishing_point([[600, 400], [680, 400], [840, 600], [440, 600]])
    (640.0, 350.0)
    """
    (x0, y0), (x1, y1), (x2, y2), (x3, y3) = np.asarray(src_px, np.float64)
    v = np.cross(np.cross([x0, y0, 1], [x3, y3, 1]), np.cross([x1, y1, 1], [x2, y2, 1]))
    if abs(v[2]) < 1e-12:
        return math.nan, math.nan
    return float(v[0] / v[2]), float(v[1] / v[2])


def setup_of(be: BirdsEye) -> tuple[float, float, float]:
    """Give the horizon row, camera height and focal length a bird's-eye set-up implies.

    Parameters
    ----------
    be : BirdsEye
        The set-up.

    Returns
    -------
    horizon_px, height_m, focal_px : float
        Frame pixels, metres, pixels.

    Examples
    --------
    >>> from lanefinder import LaneFinder
    >>> h, z, f = setup_of(LaneFinder().birdseye((1280, 720)))
    >>> round(h), round(z, 2), round(f)
    (419, 1.26, 1161)
    """
    horizon = src_vanishing_point(be.src_px)[1]
    r1, r2, t, _ = plane_pose(be.camera.camera_matrix, be.matrix, be.xm_per_px, be.ym_per_px)
    n = np.cross(r1, r2)
    return horizon, float(abs(t @ n) / np.linalg.norm(n)), float(be.camera.camera_matrix[0, 0])


def make_birdseye(
    camera: CameraModel,
    src_px: np.ndarray,
    dst_px: np.ndarray,
    size: tuple[int, int],
    xm_per_px: float,
    ym_per_px: float,
) -> BirdsEye:
    """Build the set-up and its combined undistort+warp remap tables.

    Parameters
    ----------
    camera : CameraModel
        The lens model at the frame size.
    src_px : (4, 2) array_like
        A road trapezoid in undistorted pixels of ``camera.image_size``.
    dst_px : (4, 2) array_like
        The rectangle it maps to, bird's-eye pixels.
    size : tuple of int
        (width, height) of the bird's-eye image, pixels.
    xm_per_px, ym_per_px : float
        Metres per bird's-eye pixel across and along the road.

    Returns
    -------
    BirdsEye
        The set-up; ``warp`` takes a raw frame to the view in one remap.

    Examples
    --------
    >>> from lanefinder.camera import udacity_camera
    >>> from lanefinder.config import default_dst
    >>> src = [[585, 455], [700, 455], [1120, 720], [190, 720]]
    >>> be = make_birdseye(udacity_camera(), src, default_dst(), (400, 300), 0.0185, 0.1)
    >>> be.warp(np.zeros((720, 1280, 3), np.uint8)).shape
    (300, 400, 3)
    """
    src = np.asarray(src_px, np.float32).reshape(4, 2)
    dst = np.asarray(dst_px, np.float32).reshape(4, 2)
    m = cv2.getPerspectiveTransform(src, dst)
    m_inv = np.linalg.inv(m)
    k = camera.camera_matrix
    # initUndistortRectifyMap sends output pixel p to the ray inv(newK @ R) p, then distorts it
    # with (K, dist).  With newK = M @ K and R = I that ray is inv(K) @ inv(M) @ p: the
    # undistorted pixel M^-1 p, exactly what one remap from raw frame to bird's-eye needs.
    map1, map2 = cv2.initUndistortRectifyMap(k, camera.dist_coeffs, None, m @ k, size, cv2.CV_16SC2)
    car_x, car_y = camera_foot_px(camera.camera_matrix, m, xm_per_px, ym_per_px)
    return BirdsEye(camera, src, dst, (int(size[0]), int(size[1])), float(xm_per_px), float(ym_per_px),
                    m, m_inv, map1, map2, float(car_x), float(car_y))

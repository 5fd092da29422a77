"""Bird's-eye view: one remap from the distorted frame to a top-down view of the road.

Coordinates: frame and bird's-eye pixels are (x, y), origin top-left.  In the
bird's-eye image the car is at the bottom row and y grows towards the car.

The homography ``M`` maps *undistorted* frame pixels to bird's-eye pixels.  The
remap tables combine lens undistortion with ``M``, so a single ``cv2.remap``
takes the raw frame straight to the bird's-eye image.  Points go back onto the
raw (distorted) frame exactly: inverse homography, then the forward lens model.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from .camera import CameraModel, distort_points, undistort_points


@dataclass(frozen=True, eq=False)
class BirdsEye:
    """A bird's-eye set-up for one camera at one frame size.

    src_px: 4x2 trapezoid in undistorted frame pixels; dst_px: 4x2 rectangle in bird's-eye pixels.
    size: (width, height) of the bird's-eye image in pixels.
    xm_per_px, ym_per_px: metres per bird's-eye pixel across and along the road.
    car_x_px: bird's-eye x of the road point right below the camera (see :func:`camera_foot_px`).
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

    @property
    def frame_size(self) -> tuple[int, int]:
        return self.camera.image_size

    def warp(self, frame: np.ndarray, interpolation: int = cv2.INTER_LINEAR) -> np.ndarray:
        """Raw (distorted) frame -> bird's-eye image, in one remap."""
        return cv2.remap(frame, self.map1, self.map2, interpolation, borderMode=cv2.BORDER_REPLICATE)

    def warp_undistorted(self, image: np.ndarray) -> np.ndarray:
        """An already undistorted frame -> bird's-eye image (for figures)."""
        return cv2.warpPerspective(image, self.matrix, self.size, flags=cv2.INTER_LINEAR)

    def to_frame(self, points: np.ndarray) -> np.ndarray:
        """Bird's-eye pixels (Nx2) -> raw frame pixels (Nx2), exact inverse of :meth:`warp`."""
        undist = cv2.perspectiveTransform(np.asarray(points, np.float64).reshape(-1, 1, 2), self.matrix_inv)
        return distort_points(self.camera, undist.reshape(-1, 2))

    def to_undistorted(self, points: np.ndarray) -> np.ndarray:
        """Bird's-eye pixels (Nx2) -> undistorted frame pixels (Nx2)."""
        pts = np.asarray(points, np.float64).reshape(-1, 1, 2)
        return cv2.perspectiveTransform(pts, self.matrix_inv).reshape(-1, 2)

    def from_frame(self, points: np.ndarray) -> np.ndarray:
        """Raw frame pixels (Nx2) -> bird's-eye pixels (Nx2)."""
        undist = undistort_points(self.camera, points)
        return cv2.perspectiveTransform(undist.reshape(-1, 1, 2), self.matrix).reshape(-1, 2)


def plane_pose(camera_matrix: np.ndarray, matrix: np.ndarray, xm_per_px: float,
               ym_per_px: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """The road plane seen by the camera, from the bird's-eye set-up.

    A road point at metric bird's-eye coordinates (X, Y) = (u*xm, v*ym) images at
    K [r1 r2 t] (X, Y, 1); returns r1, r2 (unit), t (metres, camera frame) and the scale
    ratio |r1|/|r2| before normalising (1.0 when xm and ym agree with the camera).
    """
    b = np.linalg.inv(camera_matrix) @ np.linalg.inv(matrix) @ np.diag([1.0 / xm_per_px, 1.0 / ym_per_px, 1.0])
    b = b * (1.0 if b[2, 2] >= 0 else -1.0)  # the homogeneous sign that puts the road in front
    n1, n2 = np.linalg.norm(b[:, 0]), np.linalg.norm(b[:, 1])
    return b[:, 0] / n1, b[:, 1] / n2, b[:, 2] / np.sqrt(n1 * n2), float(n1 / n2)


def camera_foot_px(camera_matrix: np.ndarray, matrix: np.ndarray, xm_per_px: float,
                   ym_per_px: float) -> tuple[float, float]:
    """Bird's-eye (x, y) of the road point right below the camera: the car's position.

    Its x is the camera's lateral place, which the offset is measured from; it allows for the
    camera's yaw and principal point, unlike "the image's centre column".
    """
    r1, r2, t, _ = plane_pose(camera_matrix, matrix, xm_per_px, ym_per_px)
    # The bird's-eye axes need not be orthogonal on the road (rows of the frame run square to
    # the camera axis, columns along the lane), so solve for the nearest road point in their basis.
    gram = np.array([[r1 @ r1, r1 @ r2], [r1 @ r2, r2 @ r2]])
    x_m, y_m = np.linalg.solve(gram, -np.array([t @ r1, t @ r2]))
    return float(x_m / xm_per_px), float(y_m / ym_per_px)


def make_birdseye(
    camera: CameraModel,
    src_px: np.ndarray,
    dst_px: np.ndarray,
    size: tuple[int, int],
    xm_per_px: float,
    ym_per_px: float,
) -> BirdsEye:
    """Build the set-up and its combined undistort+warp remap tables.

    ``src_px`` is in undistorted pixels of ``camera.image_size``.
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
    car_x = camera_foot_px(camera.camera_matrix, m, xm_per_px, ym_per_px)[0]
    return BirdsEye(camera, src, dst, (int(size[0]), int(size[1])), float(xm_per_px), float(ym_per_px),
                    m, m_inv, map1, map2, float(car_x))

"""The classroom pipeline, written the way it usually is: the baseline that bench.py compares with.

Full-frame undistort, full-frame warpPerspective, Sobel with large kernels on several
channels, sliding windows as a Python loop over windows, each masking every set pixel again,
and the lane drawn on a bird's-eye canvas that is warped back over the whole frame.
"""

from __future__ import annotations

import cv2
import numpy as np


class NaivePipeline:
    def __init__(self, camera_matrix: np.ndarray, dist: np.ndarray, src: np.ndarray, size=(1280, 720)):
        self.k, self.dist = camera_matrix, dist
        dst = np.float32([(250, 0), (1000, 0), (1000, 720), (250, 720)])
        self.m = cv2.getPerspectiveTransform(np.float32(src), dst)
        self.m_inv = cv2.getPerspectiveTransform(dst, np.float32(src))
        self.size = size
        self.ym, self.xm = 30 / 720, 3.7 / 700

    def binary(self, img: np.ndarray) -> np.ndarray:
        hls = cv2.cvtColor(img, cv2.COLOR_BGR2HLS)
        l_ch, s_ch = hls[:, :, 1], hls[:, :, 2]
        out = np.zeros_like(s_ch)
        for ch in (l_ch, s_ch):
            sx = cv2.Sobel(ch, cv2.CV_64F, 1, 0, ksize=9)
            sy = cv2.Sobel(ch, cv2.CV_64F, 0, 1, ksize=9)
            ax = np.uint8(255 * np.abs(sx) / max(np.max(np.abs(sx)), 1e-9))
            mag = np.sqrt(sx**2 + sy**2)
            mag = np.uint8(255 * mag / max(np.max(mag), 1e-9))
            direction = np.arctan2(np.abs(sy), np.abs(sx))
            out[((ax >= 20) & (ax <= 100)) | ((mag >= 30) & (mag <= 100) & (direction > 0.7) & (direction < 1.3))] = 1
        out[(s_ch >= 170)] = 1
        return out

    def windows(self, warped: np.ndarray, nwindows: int = 9, margin: int = 100, minpix: int = 50):
        hist = np.sum(warped[warped.shape[0] // 2:, :], axis=0)
        mid = hist.shape[0] // 2
        leftx_current, rightx_current = np.argmax(hist[:mid]), np.argmax(hist[mid:]) + mid
        window_height = warped.shape[0] // nwindows
        left_inds, right_inds = [], []
        nonzero = warped.nonzero()
        nonzeroy, nonzerox = np.array(nonzero[0]), np.array(nonzero[1])
        for window in range(nwindows):
            y_low = warped.shape[0] - (window + 1) * window_height
            y_high = warped.shape[0] - window * window_height
            good_left = ((nonzeroy >= y_low) & (nonzeroy < y_high) & (nonzerox >= leftx_current - margin)
                         & (nonzerox < leftx_current + margin)).nonzero()[0]
            good_right = ((nonzeroy >= y_low) & (nonzeroy < y_high) & (nonzerox >= rightx_current - margin)
                          & (nonzerox < rightx_current + margin)).nonzero()[0]
            left_inds.append(good_left)
            right_inds.append(good_right)
            if len(good_left) > minpix:
                leftx_current = int(np.mean(nonzerox[good_left]))
            if len(good_right) > minpix:
                rightx_current = int(np.mean(nonzerox[good_right]))
        li, ri = np.concatenate(left_inds).astype(int), np.concatenate(right_inds).astype(int)
        return nonzerox[li], nonzeroy[li], nonzerox[ri], nonzeroy[ri]

    def process(self, img: np.ndarray) -> tuple[np.ndarray, float]:
        undist = cv2.undistort(img, self.k, self.dist)
        binary = self.binary(undist)
        warped = cv2.warpPerspective(binary, self.m, self.size, flags=cv2.INTER_LINEAR)
        lx, ly, rx, ry = self.windows(warped)
        if len(lx) < 3 or len(rx) < 3:
            return undist, float("nan")
        lf, rf = np.polyfit(ly, lx, 2), np.polyfit(ry, rx, 2)
        y_eval = 719
        lcr = np.polyfit(ly * self.ym, lx * self.xm, 2)
        radius = (1 + (2 * lcr[0] * y_eval * self.ym + lcr[1]) ** 2) ** 1.5 / abs(2 * lcr[0])
        ploty = np.linspace(0, 719, 720)
        lfx, rfx = np.polyval(lf, ploty), np.polyval(rf, ploty)
        canvas = np.zeros_like(img)
        pts = np.hstack((np.array([np.transpose(np.vstack([lfx, ploty]))]),
                         np.array([np.flipud(np.transpose(np.vstack([rfx, ploty])))])))
        cv2.fillPoly(canvas, np.int_([pts]), (0, 255, 0))
        back = cv2.warpPerspective(canvas, self.m_inv, self.size)
        out = cv2.addWeighted(undist, 1, back, 0.3, 0)
        cv2.putText(out, f"Radius: {radius:.0f} m", (50, 50), cv2.FONT_HERSHEY_SIMPLEX, 1.5, (255, 255, 255), 2)
        return out, radius

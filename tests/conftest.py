from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "data"
CAL = DATA / "camera_cal"
TEST_IMAGES = DATA / "test_images"
CLIPS = DATA / "clips"
SHARED_VIDEOS = ROOT.parent / "shared" / "data" / "udacity" / "videos"


@pytest.fixture(scope="session")
def udacity_camera():
    from lanefinder.camera import udacity_camera

    return udacity_camera()


@pytest.fixture(scope="session")
def test_images() -> dict[str, np.ndarray]:
    return {p.stem: cv2.imread(str(p)) for p in sorted(TEST_IMAGES.glob("*.jpg"))}


def shared_video(name: str) -> Path:
    path = SHARED_VIDEOS / f"{name}.mp4"
    if not path.is_file():
        pytest.skip(f"full Udacity video not available: {path} (needs ../shared/data beside the checkout)")
    return path

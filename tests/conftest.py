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


def faststart_copy(src: Path, dst: Path) -> None:
    """Remux an MP4 with its index (moov) in front, as streaming-friendly files have it."""
    remux(src, dst, "mp4", {"movflags": "faststart"})


def remux(src: Path, dst: Path, fmt: str | None = None, options: dict | None = None) -> None:
    """Copy a video's packets into another container (no re-encoding)."""
    import av

    with av.open(str(src)) as i, av.open(str(dst), "w", format=fmt, options=options or {}) as o:
        s_in = i.streams.video[0]
        s_out = o.add_stream_from_template(s_in)
        for pkt in i.demux(s_in):
            if pkt.dts is not None:
                pkt.stream = s_out
                o.mux(pkt)


#: Doctests that run a real job (a Dask cluster, video encoding): left out of `make test-fast`.
SLOW_DOCTESTS = {"lanefinder.batch.run_batch"}


#: Test files, slowest first (measured with `--durations=0`): `make test` hands whole files to its
#: two processes in this order (`--no-loadscope-reorder`), so that the last ones to run are short
#: and both processes finish together.  Files not listed follow, in their own order.
SLOWEST_FILES = ("test_batch.py", "test_generalise.py", "test_reliability.py", "test_full_videos.py",
                 "test_selfcal.py", "test_synth_accuracy.py", "test_review.py", "test_video.py", "test_cli.py",
                 "test_scripts.py", "test_synth.py", "test_events.py", "test_autosetup.py", "test_camera.py")


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    for item in items:
        if item.name in SLOW_DOCTESTS:
            item.add_marker(pytest.mark.slow)
    rank = {name: i for i, name in enumerate(SLOWEST_FILES)}
    items.sort(key=lambda item: rank.get(item.path.name, len(SLOWEST_FILES)))  # stable: files stay whole

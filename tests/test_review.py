"""lanefinder review: the API (TestClient) and the page in a real browser (Playwright, system Chromium)."""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import socket
import subprocess
import sys
import threading
import time
import urllib.request
from pathlib import Path

import pytest

from lanefinder import Config, load_config
from lanefinder.errors import LaneFinderError
from lanefinder.review import MAX_BODY_BYTES, Review, create_app, serve
from lanefinder.telemetry import read_telemetry

from clirun import run_lanefinder
from conftest import CLIPS, ROOT

CHALLENGE = CLIPS / "challenge_3-7s.mp4"
HARDER = CLIPS / "harder_challenge_0-4s.mp4"
CHROMIUM = os.environ.get("LANEFINDER_CHROMIUM", "/usr/bin/chromium")
SHOTS = ROOT / "output"


@pytest.fixture(scope="module")
def fleet_dir(tmp_path_factory):
    from lanefinder.batch import run_batch

    d = tmp_path_factory.mktemp("review")
    (d / "in").mkdir()
    shutil.copy(CHALLENGE, d / "in" / "challenge.mp4")
    shutil.copy(HARDER, d / "in" / "harder.mp4")
    (d / "in" / "broken.mp4").write_bytes(b"not a video" * 100)
    # Warnings 0.4 m before a wheel reaches a line, so the short clips hold events to jump to.
    # (No self-calibration: not what is tested here, and on these short clips the most of the cost.)
    cfg = Config.model_validate({"events": {"warning_margin_m": 0.4}, "selfcal": {"enabled": False}})
    run_batch([d / "in"], d / "out", cfg, workers=1, progress=False)
    return d / "out"


@pytest.fixture()
def client(fleet_dir):
    from fastapi.testclient import TestClient

    return TestClient(create_app(Review(fleet_dir)))


@pytest.mark.slow  # a batch over two clips (the fleet) or a video run
def test_api_lists_the_fleet_and_serves_frames(client):
    videos = {v["video"]: v for v in client.get("/api/videos").json()}
    assert set(videos) == {"challenge", "harder", "broken"}
    assert videos["broken"]["status"] == "failed" and videos["harder"]["frames"] == 100
    info = client.get("/api/videos/challenge").json()
    assert info["frames"] == 120 and len(info["series"]["offset_m"]) == 120 and info["events"]
    # Why the run refused lines, per frame (the telemetry's checks): text, "" where nothing was refused.
    harder = client.get("/api/videos/harder").json()["series"]["checks"]
    assert len(harder) == 100 and all(isinstance(c, str) for c in harder) and any(harder) and not all(harder)
    r = client.get("/api/videos/harder/frames/50.jpg")
    assert r.status_code == 200 and r.headers["content-type"] == "image/jpeg" and r.content[:2] == b"\xff\xd8"
    r = client.post("/api/videos/harder/frames/50/inspect", json={"config": {"threshold.ridge.min_contrast": 30}})
    assert r.status_code == 200 and set(r.json()["images"]) >= {"2_binary", "5_windows", "6_final"}


@pytest.mark.slow  # a batch over two clips (the fleet) or a video run
@pytest.mark.parametrize(("url", "status", "message"), [
    ("/api/videos/harder/frames/100.jpg", 404, "frame 100 is out of range 0..99"),
    ("/api/videos/harder/frames/-1.jpg", 404, "out of range"),
    ("/api/videos/harder/frames/abc.jpg", 422, ""),
    ("/api/videos/nope/frames/0.jpg", 404, "no video 'nope'"),
    ("/files/../manifest.json", 404, ""),
    ("/files/%2e%2e/%2e%2e/etc/passwd", 404, ""),
    ("/files//etc/passwd", 404, ""),
    ("/files/telemetry/../../out/summary.csv", 404, ""),
    ("/static/../review.py", 404, ""),
])
def test_api_refuses_what_lies_outside_and_bad_indices(client, url, status, message):
    r = client.get(url)
    assert r.status_code == status, r.text
    if message:
        assert message in r.json()["detail"]


@pytest.mark.slow  # a batch over two clips (the fleet) or a video run
def test_api_serves_files_under_the_folder_but_no_symlink_out(client, fleet_dir):
    assert client.get("/files/summary.csv").text.startswith("video,input,status")
    link = fleet_dir / "escape.txt"
    link.symlink_to("/etc/hostname")
    try:
        assert client.get("/files/escape.txt").status_code == 404
    finally:
        link.unlink()


@pytest.mark.slow  # a batch over two clips (the fleet) or a video run
def test_api_refuses_bad_config_values_and_large_bodies(client):
    url = "/api/videos/harder/frames/0/inspect"
    r = client.post(url, json={"config": {"threshold.ridge.min_contrast": -5}})
    assert r.status_code == 422 and "threshold.ridge.min_contrast" in r.json()["detail"]
    r = client.post(url, json={"config": {"camera.model": "x"}})
    assert r.status_code == 422 and "only threshold, search, tracking, render" in r.json()["detail"]
    r = client.post(url, json={"config": {"search.no_such_key": 1}})
    assert r.status_code == 422 and "no such setting" in r.json()["detail"]
    r = client.post(url, json={"src": [[0, 0], [1, 1]]})
    assert r.status_code == 422
    big = b"{" + b" " * (MAX_BODY_BYTES + 10) + b"}"
    r = client.post(url, content=big, headers={"content-type": "application/json"})
    assert r.status_code == 413


@pytest.mark.slow  # a batch over two clips (the fleet) or a video run
def test_saved_config_is_atomic_and_never_over_an_input(fleet_dir):
    from fastapi.testclient import TestClient

    cfg_in = fleet_dir / "review-config.toml"
    cfg_in.write_text("[search]\nn_windows = 10\n")
    try:
        client = TestClient(create_app(Review(fleet_dir, load_config(cfg_in), cfg_in)))
        r = client.post("/api/config/save", json={"config": {"threshold.ridge.min_contrast": 25}})
        saved = Path(r.json()["path"])
        assert saved.name == "review-config-2.toml" and cfg_in.read_text() == "[search]\nn_windows = 10\n"
        cfg = load_config(saved)
        assert cfg.search.n_windows == 10 and cfg.threshold.ridge.min_contrast == 25
        assert not [p for p in fleet_dir.iterdir() if p.name.startswith(".")]
    finally:
        cfg_in.unlink()
        (fleet_dir / "review-config-2.toml").unlink(missing_ok=True)


@pytest.mark.slow  # a batch over two clips (the fleet) or a video run
def test_another_lens_shows_and_tunes_the_setup_in_use(fleet_dir, tmp_path):
    from fastapi.testclient import TestClient

    from lanefinder.camera import CameraModel, save_camera
    from lanefinder.pipeline import birdseye_config_used, camera_from_config

    save_camera(CameraModel.ideal((1280, 720), hfov_deg=90.0), tmp_path / "wide.json")
    cfg = Config.model_validate({"camera": {"model": str(tmp_path / "wide.json")}})
    used = birdseye_config_used(cfg, camera_from_config(cfg, (1280, 720)), (1280, 720))
    assert used.src != cfg.birdseye.src  # the lens's nominal set-up, not the Udacity lens's trapezoid
    client = TestClient(create_app(Review(fleet_dir, cfg)))
    info = client.get("/api/videos/harder").json()
    assert info["src"] == [list(p) for p in used.src] and info["reference_size"] == [1280, 720]
    dragged = [[x + 4.0, y] for x, y in used.src]
    body = {"src": dragged, "reference_size": [1280, 720], "video": "harder"}
    r = client.post("/api/videos/harder/frames/0/inspect", json=body).json()
    assert r["src"] == dragged and r["reference_size"] == [1280, 720]
    saved = Path(client.post("/api/config/save", json=body).json()["path"])
    try:
        b = load_config(saved).birdseye
        assert [list(p) for p in b.src] == dragged and b.xm_per_px == used.xm_per_px  # the nominal scales kept
    finally:
        saved.unlink()
    # Saved only with the video it was drawn on, and only when it can serve that video.
    for bad, status, message in ((dict(body, video="nosuch"), 404, "no video"),
                                 ({"src": dragged}, 422, "give 'video'"),
                                 (dict(body, reference_size=[1000, 1000]), 422, "aspect ratio"),
                                 ({"reference_size": [1280, 720]}, 422, "reference_size goes with src"),
                                 (dict(body, reference_size=[1280.5, 720]), 422, "reference_size.0: ")):
        r = client.post("/api/config/save", json=bad)
        assert r.status_code == status and message in r.json()["detail"], bad
    assert not list(fleet_dir.glob("review-config*.toml"))


@pytest.mark.slow  # a batch over two clips (the fleet) or a video run
def test_a_video_with_its_telemetry_and_bad_paths(tmp_path):
    from lanefinder.errors import LaneFinderError
    from lanefinder.videojob import process_video

    shutil.copy(HARDER, tmp_path / "h.mp4")
    with pytest.raises(LaneFinderError, match="no telemetry beside"):
        Review(tmp_path / "h.mp4")
    process_video(tmp_path / "h.mp4", None, telemetry=tmp_path / "h.parquet", progress=False)
    assert Review(tmp_path / "h.mp4").videos["h"].summary["frames"] == 100
    with pytest.raises(LaneFinderError, match="not a lanefinder batch folder"):
        Review(CLIPS)
    # A bad-input campaign: a row whose left_x was not numbers made the frame endpoint an HTTP 500;
    # a negative frame was "has no frame number"; a repeated frame was reported as an event-row error.
    from lanefinder.telemetry import read_telemetry

    rows = read_telemetry(tmp_path / "h.parquet")
    for change, says in (({"left_x": ["a"] * 32}, "row 1: left_x must be a list of numbers"),
                         ({"frame": -5}, r"row 1: frame must be a whole number, 0 or more \(-5\)"),
                         ({"frame": 1}, "row 2: frame 1 is given twice")):
        bad = [{**rows[0], **change}, *rows[1:]]
        (tmp_path / "h.jsonl").write_text("".join(json.dumps(r, default=float) + "\n" for r in bad))
        with pytest.raises(LaneFinderError, match=says):
            Review(tmp_path / "h.mp4", telemetry=tmp_path / "h.jsonl").videos["h"].rows()


# -- in a real browser ----------------------------------------------------------------------------
@pytest.fixture(scope="module")
def server(fleet_dir):
    import uvicorn

    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))
    port = sock.getsockname()[1]
    srv = uvicorn.Server(uvicorn.Config(create_app(Review(fleet_dir)), log_level="warning"))
    thread = threading.Thread(target=srv.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    deadline = time.time() + 20
    while not srv.started and time.time() < deadline:
        time.sleep(0.05)
    yield f"http://127.0.0.1:{port}"
    srv.should_exit = True
    thread.join(timeout=10)


@pytest.fixture(scope="module")
def page(server):
    if not Path(CHROMIUM).is_file():
        pytest.skip(f"no Chromium at {CHROMIUM} (Debian's chromium package; .ci/run installs it)")
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=[
            "--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
            "--disable-background-networking", "--disable-component-update", "--disable-sync"])
        page = browser.new_page(viewport={"width": 1500, "height": 1400})
        page.set_default_timeout(20_000)
        yield page
        browser.close()


@pytest.mark.slow
def test_the_page_in_a_browser(page, server, fleet_dir, tmp_path):
    SHOTS.mkdir(exist_ok=True)
    failed: list[str] = []  # no request of the page's fails
    page.on("response", lambda r: failed.append(f"{r.status} {r.url}") if r.status >= 400 else None)
    page.goto(server + "/")
    page.wait_for_selector("body[data-ready='1']")
    # Fleet view: three rows, sortable.
    assert page.locator("#fleet tbody tr").count() == 3
    page.click("#fleet th[data-key='frames']")
    assert page.locator("#fleet tbody tr").first.get_attribute("data-video") == "harder"
    page.screenshot(path=str(SHOTS / "review_fleet.png"))
    # Open the challenge clip.
    page.click("#fleet tbody tr[data-video='challenge']")
    page.wait_for_function("document.getElementById('status').dataset.seq >= 1")
    assert page.locator("#slider").input_value() == "0"
    # Seek by clicking the plot, about 60% along the time axis.
    box = page.locator("#plots .xy .nsewdrag").first.bounding_box()
    page.mouse.click(box["x"] + 0.6 * box["width"], box["y"] + box["height"] / 2)
    page.wait_for_function("Number(document.getElementById('slider').value) > 50")
    assert 60 <= int(page.locator("#slider").input_value()) <= 85
    # Jump to the first event.
    first = page.locator("#events li").first
    target = first.get_attribute("data-frame")
    first.click()
    page.wait_for_function(f"document.getElementById('slider').value === '{target}'")
    assert page.locator("#frame").get_attribute("src").endswith(f"/frames/{target}.jpg")
    page.wait_for_function(f"document.getElementById('status').textContent.startsWith('frame {target} ')")
    # Under the frame, what the tracked run said there: its state and the checks that refused something.
    run = {r["frame"]: r for p in sorted((fleet_dir / "telemetry" / "video=challenge").glob("*.parquet"))
           for r in read_telemetry(p)}[int(target)]
    said = f"the run: {run['state']}" + (f"; checks: {', '.join(run['checks'].split(','))}" if run["checks"] else "")
    assert page.locator("#run-label").text_content() == said
    page.screenshot(path=str(SHOTS / "review_video.png"))
    # Change a threshold: the binary image changes.
    before = page.locator("#stage-2_binary").get_attribute("src")
    seq = int(page.locator("#status").get_attribute("data-seq"))
    page.fill("input[name='threshold.ridge.min_contrast']", "60")
    page.dispatch_event("input[name='threshold.ridge.min_contrast']", "change")
    page.wait_for_function(f"Number(document.getElementById('status').dataset.seq) > {seq}")
    assert page.locator("#stage-2_binary").get_attribute("src") != before
    ms = float(page.locator("#status").get_attribute("data-ms"))
    # A choice of numbers goes back as a number (the page once sent the text "7", which is refused).
    seq = int(page.locator("#status").get_attribute("data-seq"))
    page.select_option("select[name='threshold.sobel_hls.kernel']", "7")
    page.wait_for_function(f"Number(document.getElementById('status').dataset.seq) > {seq}")
    assert not failed
    # Drag the top-left corner of the trapezoid 40 px to the left.
    seq = int(page.locator("#status").get_attribute("data-seq"))
    page.locator("#corner-0").scroll_into_view_if_needed()
    corner = page.locator("#corner-0").bounding_box()
    x, y = corner["x"] + corner["width"] / 2, corner["y"] + corner["height"] / 2
    page.mouse.move(x, y)
    page.mouse.down()
    page.mouse.move(x - 20, y, steps=5)
    page.mouse.move(x - 40, y, steps=5)
    page.mouse.up()
    page.wait_for_function(f"Number(document.getElementById('status').dataset.seq) > {seq}")
    cx = float(page.locator("#corner-0").get_attribute("cx"))
    assert cx < Config().birdseye.src[0][0] - 10
    page.locator("#stages").screenshot(path=str(SHOTS / "review_inspector.png"))
    # Save, and run a video with the saved config.
    page.click("#save")
    page.wait_for_function("document.getElementById('status').dataset.saved")
    saved = Path(page.locator("#status").get_attribute("data-saved"))
    try:
        cfg = load_config(saved)
        assert cfg.threshold.ridge.min_contrast == 60 and abs(cfg.birdseye.src[0][0] - cx) < 0.2
        assert cfg.threshold.sobel_hls.kernel == 7
        out = run_lanefinder("video", str(HARDER), "-c", str(saved),
                             "--telemetry", str(tmp_path / "t.csv"), "--end", "1", "--quiet", timeout=120)
        assert out.returncode == 0, out.stderr
        assert "frames: 25" in out.stdout
    finally:
        saved.unlink()
    page.screenshot(path=str(SHOTS / "review_page.png"), full_page=True)
    assert not failed, failed
    print(f"live re-render: {ms} ms on the server")


def test_a_video_review_serves_no_sibling_and_answers_only_local_names(tmp_path):
    from fastapi.testclient import TestClient

    from lanefinder.videojob import process_video

    shutil.copy(HARDER, tmp_path / "h.mp4")
    (tmp_path / "secret.txt").write_text("not for the page")
    process_video(tmp_path / "h.mp4", None, telemetry=tmp_path / "h.csv", progress=False, max_frames=5)
    client = TestClient(create_app(Review(tmp_path / "h.mp4")))
    assert client.get("/files/secret.txt").status_code == 404
    assert client.get("/files/h.csv").status_code == 200
    assert client.get("/api/videos", headers={"host": "evil.example.com"}).status_code == 400

    def chunks():
        for _ in range(10):
            yield b" " * (MAX_BODY_BYTES // 4)

    r = client.post("/api/config/save", content=chunks(), headers={"content-type": "application/json"})
    assert r.status_code == 413 and not list(tmp_path.glob("review-config*"))
    # A video whose telemetry lies in an output folder: a saved config goes beside the telemetry,
    # not into the video's (input) folder.
    out = tmp_path / "out"
    out.mkdir()
    shutil.move(tmp_path / "h.csv", out / "h.csv")
    review = Review(tmp_path / "h.mp4", telemetry=out / "h.csv")
    assert review.save_config(review.config) == (out / "review-config.toml").resolve()
    assert not list(tmp_path.glob("review-config*"))


def test_telemetry_without_frame_numbers_is_one_line(tmp_path):
    from lanefinder.errors import LaneFinderError

    shutil.copy(HARDER, tmp_path / "h.mp4")
    (tmp_path / "h.csv").write_text("time_s,state\n0.0,lost\n")
    with pytest.raises(LaneFinderError, match="row 1 has no frame number"):
        Review(tmp_path / "h.mp4")


def test_empty_telemetry_or_another_video_s_is_one_line(tmp_path):
    from lanefinder.errors import LaneFinderError

    shutil.copy(HARDER, tmp_path / "h.mp4")
    (tmp_path / "h.csv").write_text("")  # served an empty page before
    with pytest.raises(LaneFinderError, match=r"h\.csv has no rows"):
        Review(tmp_path / "h.mp4")
    (tmp_path / "h.csv").write_text("frame,time_s,state\n0,0.0,lost\n1000000000000,40000000000.0,lost\n")
    with pytest.raises(LaneFinderError, match=r"runs to frame 1000000000000, but h\.mp4 has about 100 frames"):
        Review(tmp_path / "h.mp4")


@pytest.mark.slow
def test_ctrl_c_stops_a_review_cleanly(tmp_path):
    import signal

    shutil.copy(HARDER, tmp_path / "h.mp4")
    assert subprocess.run([sys.executable, "-m", "lanefinder", "video", str(tmp_path / "h.mp4"), "--telemetry",
                           str(tmp_path / "h.csv"), "--end", "0.5", "--quiet"], timeout=120).returncode == 0
    p = subprocess.Popen([sys.executable, "-m", "lanefinder", "review", str(tmp_path / "h.mp4"), "--port", "0"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        url = p.stdout.readline().split()[-4]  # "... http://127.0.0.1:PORT/  (Ctrl-C to stop)"
        deadline = time.time() + 30
        while time.time() < deadline:  # until it answers
            with contextlib.suppress(OSError):
                urllib.request.urlopen(url, timeout=2).close()
                break
            time.sleep(0.1)
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=30)
    finally:
        p.kill()
    assert p.returncode == 0 and "review stopped" in out and not err.strip(), (p.returncode, out, err)


def test_telemetry_written_before_the_checks_column_is_reviewed_without_them(tmp_path):
    import csv

    from fastapi.testclient import TestClient

    from lanefinder.stats import check_counts, unchecked_frames
    from lanefinder.videojob import process_video

    # An older run's CSV: no checks column, so the page says none were recorded (null), not "none fired".
    shutil.copy(HARDER, tmp_path / "h.mp4")
    process_video(tmp_path / "h.mp4", None, telemetry=tmp_path / "new.csv", progress=False, max_frames=5)
    with open(tmp_path / "new.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    with open(tmp_path / "h.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=[k for k in rows[0] if k != "checks"], extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    series = TestClient(create_app(Review(tmp_path / "h.mp4"))).get("/api/videos/h").json()["series"]
    assert series["checks"] == [None] * 5 and series["state"][0] == "re-detect"
    old = read_telemetry(tmp_path / "h.csv")
    assert check_counts(old) == {} and unchecked_frames(old) is None
    assert all(isinstance(r["checks"], str) for r in read_telemetry(tmp_path / "new.csv"))


@pytest.mark.slow  # a batch over two clips (the fleet)
def test_a_video_replaced_after_its_batch_is_flagged(fleet_dir):
    # A bad-input campaign: a source video replaced after the batch was shown with the old
    # telemetry drawn on it, without a word. Now `lanefinder review` warns at start.
    src = fleet_dir.parent / "in" / "harder.mp4"
    before = src.stat()
    assert not any(v.changed for v in Review(fleet_dir).videos.values())
    saved = src.read_bytes()
    try:
        os.utime(src, (before.st_atime, time.time() + 60))  # a copy made after the batch: the same video
        assert not any(v.changed for v in Review(fleet_dir).videos.values())
        shutil.copy(fleet_dir.parent / "in" / "challenge.mp4", src)  # replaced by another
        os.utime(src, (before.st_atime, time.time() + 60))
        review = Review(fleet_dir)
        assert [v.video_id for v in review.videos.values() if v.changed] == ["harder"]
        said: list[str] = []
        with pytest.raises(LaneFinderError):  # a port that cannot be bound: it stops after what it says first
            serve(review, port=-1, echo=said.append)
        assert said and "1 video(s) were modified after their telemetry was written" in said[0] and "harder" in said[0]
    finally:
        src.write_bytes(saved)
        os.utime(src, (before.st_atime, before.st_mtime))

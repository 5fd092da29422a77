"""Lane events: departures, lane changes and lost stretches, on hand-built rows, synthetic truth and the pipeline."""

from __future__ import annotations

import json
import math
import shutil
from fractions import Fraction

import cv2
import numpy as np
import pytest

from lanefinder.camera import CameraModel, udacity_camera
from lanefinder.config import EventsConfig, config_from_dict
from lanefinder.errors import LaneFinderError
from lanefinder.events import (
    EVENT_FIELDS,
    LaneEvent,
    detect_events,
    event_row,
    lateral_speed,
    read_events,
    write_events,
)
from lanefinder.synth import SCENARIOS, Mount, Renderer, Scenario, manoeuvre_shift, write_sequence

from clirun import run_lanefinder

FPS = 25.0
W = 3.7  # lane width, m; with the default 1.8 m car a wheel reaches a line at |offset| = 0.95 m


def rows_from(offsets, width=W, start=0, state="tracking"):
    return [{"frame": start + i, "time_s": (start + i) / FPS, "state": state if o is not None else "lost",
             "offset_m": o, "width_m": width if o is not None else None} for i, o in enumerate(offsets)]


def ramp(t, t0, t1, a, b):
    """a before t0, b after t1, linear between."""
    return a + (b - a) * np.clip((t - t0) / (t1 - t0), 0, 1)


def kinds(events):
    return [e.kind for e in events]


# -- departures ----------------------------------------------------------------------------
def test_departure_left_with_lateral_speed_and_time_to_line_crossing():
    t = np.arange(200) / FPS
    # Out towards the yellow line at 0.5 m/s to 0.35 m over it, held, back at 0.5 m/s.
    o = ramp(t, 0.0, 2.6, 0.0, -1.3) + ramp(t, 4.0, 6.6, 0.0, 1.3)
    cfg = EventsConfig(warning_margin_m=0.3)  # warn 0.3 m before the line: a time to line crossing to measure
    (e,) = detect_events(rows_from(o.tolist()), FPS, cfg)
    assert e.kind == "departure-left"
    # Distance w/2 - c/2 + o = 0.95 + o reaches 0.3 m at o = -0.65 (t = 1.30 s): first frame 33 (0.29 m).
    assert e.start_frame == 33 and e.start_s == pytest.approx(1.32)
    assert e.lateral_speed_mps == pytest.approx(0.5, abs=1e-3)
    assert e.ttlc_s == pytest.approx(0.29 / 0.5, abs=2e-3)
    assert e.min_distance_m == pytest.approx(-0.35, abs=1e-3)
    # Ends on the last frame before the distance is back above 0.3 + release 0.05 m (o > -0.6 after 5.4 s).
    assert e.end_frame in (134, 135)


def test_departure_right_at_the_line_and_sub_clip_frame_numbers():
    t = np.arange(150) / FPS
    o = ramp(t, 0.0, 3.0, 0.0, 1.2) + ramp(t, 4.0, 5.0, 0.0, -1.2)  # 0.4 m/s out, 1.2 m/s back
    rows = rows_from(o.tolist(), start=5000)  # a telemetry of a sub-clip: frames start anywhere
    for r in rows:
        r["time_s"] = r["frame"] / FPS
    (e,) = detect_events(rows, FPS)
    assert e.kind == "departure-right"
    # 0.95 - o <= 0 from o = 0.95 (t = 2.375 s): frame 60 of the clip, already 0.01 m over.
    assert e.start_frame == 5060 and e.start_s == pytest.approx(5060 / FPS)
    assert e.lateral_speed_mps == pytest.approx(0.4, abs=1e-3)
    assert e.ttlc_s == 0.0
    assert e.min_distance_m == pytest.approx(-0.25, abs=1e-3)
    assert 5000 + 4.0 * FPS < e.end_frame < 5000 + 5.0 * FPS


def test_a_near_miss_does_not_warn():
    t = np.arange(200) / FPS
    for sign in (1, -1):
        o = sign * (ramp(t, 1.0, 2.5, 0.0, 0.7) + ramp(t, 4.0, 5.5, 0.0, -0.7))  # 0.25 m inside at most
        rng = np.random.default_rng(3)
        noisy = o + rng.normal(0, 0.01, o.size)
        assert detect_events(rows_from(noisy.tolist()), FPS) == []


def test_moving_away_gives_no_time_to_line_crossing():
    # Starts already over the line and moves back in: a warning, but no crossing ahead.
    t = np.arange(60) / FPS
    o = ramp(t, 0.0, 2.0, -1.1, -0.5)
    (e,) = detect_events(rows_from(o.tolist()), FPS)
    assert e.kind == "departure-left" and e.start_frame == 0
    assert e.lateral_speed_mps == pytest.approx(-0.3, abs=1e-3) and e.ttlc_s is None


# -- lane changes --------------------------------------------------------------------------
def lane_change(direction, t, t0=1.0, dur=3.5):
    """Offsets from the ego lane for a raised-cosine move of one lane width to the right (+1) or left (-1)."""
    shift = np.array([manoeuvre_shift(((t0, dur, direction * W),), x)[0] for x in t])
    return shift - direction * W * (direction * shift >= W / 2)  # the ego lane switches when the car crosses


def test_lane_change_right_across_a_lost_gap():
    t = np.arange(170) / FPS
    o = lane_change(1, t).tolist()
    rows = rows_from(o)
    # As the tracker does: it holds the lane (misses) once the car is 1.5 m off its centre, then
    # loses it, and takes the new lane when the car is within 0.9 m of that one's centre.
    assert o[63] == pytest.approx(1.47, abs=0.01) and o[85] == pytest.approx(-0.83, abs=0.01)
    for r in rows[64:72]:
        r.update(misses=r["frame"] - 63, offset_m=rows[63]["offset_m"], state="re-detect")
    for r in rows[72:85]:
        r.update(state="lost", offset_m=None, width_m=None, misses=13)
    events = detect_events(rows, FPS)
    assert kinds(events) == ["lane-change-right", "lost"]
    e = events[0]
    # Speed 1.66 sin(pi u) m/s passes 0.2 m/s at u = 0.0385 and 0.9615: t = 1.135 s and 4.365 s.
    assert e.start_frame in (28, 29, 30) and e.end_frame in (109, 110, 111)
    assert e.lateral_speed_mps == pytest.approx(W * math.pi / 7, rel=0.03)
    assert e.ttlc_s is None and e.min_distance_m < 0
    assert (events[1].start_frame, events[1].end_frame) == (72, 84)


def test_lane_change_left_with_the_offset_jumping_up():
    t = np.arange(170) / FPS
    o = lane_change(-1, t)
    assert o.max() > 1.7 and o.min() < -1.7
    (e,) = detect_events(rows_from(o.tolist()), FPS)
    assert e.kind == "lane-change-left"
    assert e.start_frame in (28, 29, 30) and e.end_frame in (109, 110, 111)
    assert e.min_distance_m == pytest.approx(-0.9, abs=0.1)  # a wheel half a car over as the camera crosses


def test_tracker_wavering_between_two_lanes_is_not_a_change():
    o = [0.0] * 20 + [1.8, -1.8, 1.8, -1.8, 1.8] + [1.7] * 20
    assert [k for k in kinds(detect_events(rows_from(o), FPS)) if k.startswith("lane-change")] == []


# -- lost, empty, bad ----------------------------------------------------------------------
def test_lost_stretches_and_their_minimum_length():
    o = [0.0] * 10 + [None] * 10 + [0.0] * 5 + [None] * 3 + [0.0] * 5
    events = detect_events(rows_from(o), FPS)
    assert [(e.kind, e.start_frame, e.end_frame) for e in events] == [("lost", 10, 19), ("lost", 25, 27)]
    assert events[0].start_s == pytest.approx(0.4) and events[0].end_s == pytest.approx(0.76)
    assert events[0].min_distance_m is None and events[0].lateral_speed_mps is None
    assert len(detect_events(rows_from(o), FPS, EventsConfig(min_lost_frames=5))) == 1


def test_empty_single_and_none_laden_rows():
    assert detect_events([], FPS) == []
    assert detect_events([{"frame": 7}], FPS) == []  # nothing known: not even lost
    assert detect_events([{"frame": 7, "state": "tracking", "offset_m": 2.0, "width_m": 3.7}], FPS)[0].kind == \
        "departure-right"
    rows = [{"frame": i, "time_s": None, "state": None, "offset_m": None, "width_m": None} for i in range(5)]
    rows += [{"frame": i, "state": "tracking", "offset_m": float("nan"), "width_m": 3.7} for i in range(5, 9)]
    rows += [{"frame": 9, "state": "re-detect", "offset_m": 0.1, "width_m": None},
             {"frame": 20, "state": "tracking", "offset_m": 0.1, "width_m": 3.6, "misses": None}]
    assert detect_events(rows, FPS) == []
    rows[2]["state"] = "lost"
    assert [(e.kind, e.start_frame, e.end_frame) for e in detect_events(rows, FPS)] == [("lost", 2, 2)]
    assert detect_events(iter(rows_from([0.1, 0.2])), 30) == []  # any iterable, any frame rate
    assert detect_events([{"frame": 0, "state": "lost"}], Fraction(30000, 1001))[0].end_s == 0.0


@pytest.mark.parametrize(("rows", "fps", "needle"), [
    ([{"frame": 1}, {"frame": 1}], FPS, "frame order"),
    ([{"frame": 2}, {"frame": 1}], FPS, "frame order"),
    ([{"frame": 0, "time_s": 1.0}, {"frame": 1, "time_s": 1.0}], FPS, "does not follow"),
    ([{"frame": "3"}], FPS, "frame is not a whole number"),
    ([{"frame": 0, "offset_m": "abc"}], FPS, "offset_m is not a number"),
    ([{"frame": 0, "state": "asleep"}], FPS, "unknown state"),
    ([[0, 1]], FPS, "not a record"),
    ([], 0.0, "frame rate"),
    ([], float("nan"), "frame rate"),
])
def test_bad_input_is_one_line(rows, fps, needle):
    with pytest.raises(LaneFinderError, match=needle) as e:
        detect_events(rows, fps)
    assert "\n" not in str(e.value)


def test_lateral_speed_is_a_centred_least_squares_slope():
    t = np.arange(50) / FPS
    x = 0.3 * t + 0.01 * np.sin(2 * np.pi * 12.5 * t)  # a slope plus alternating noise
    v = lateral_speed(t, x, 0.4)
    assert np.allclose(v[5:-5], 0.3, atol=0.02)
    x[10:20] = np.nan
    v = lateral_speed(t, x, 0.2)
    assert np.isnan(v[14]) and np.isfinite(v[25])


def test_events_config_is_bounded():
    assert config_from_dict({"events": {"car_width_m": 2.0}}).events.car_width_m == 2.0
    for bad in ({"car_width_m": -1}, {"speed_window_s": 0}, {"min_lost_frames": 0}, {"warning_margin_m": "nan"},
                {"frames": 3}):
        with pytest.raises(LaneFinderError, match="events"):
            config_from_dict({"events": bad})


# -- files ---------------------------------------------------------------------------------
EVENTS = [LaneEvent(kind="departure-left", start_frame=3, end_frame=9, start_s=0.12, end_s=0.36,
                    lateral_speed_mps=0.4, ttlc_s=0.5, min_distance_m=-0.1),
          LaneEvent(kind="lost", start_frame=20, end_frame=29, start_s=0.8, end_s=1.16)]


@pytest.mark.parametrize("suffix", [".csv", ".jsonl", ".parquet"])
def test_write_and_read_events(tmp_path, suffix):
    path = tmp_path / f"events{suffix}"
    write_events(path, EVENTS)
    assert read_events(path) == [event_row(e) for e in EVENTS]
    assert list(read_events(path)[0]) == list(EVENT_FIELDS)
    assert [p.name for p in tmp_path.iterdir()] == [path.name]  # no hidden file left
    write_events(path, [])
    assert read_events(path) == []


def test_event_rows_are_plain_json():
    row = event_row(EVENTS[0])
    assert json.loads(json.dumps(row)) == row and tuple(row) == EVENT_FIELDS


def test_bad_event_file_names(tmp_path):
    with pytest.raises(LaneFinderError, match=r"must end in \.csv, \.jsonl or \.parquet"):
        write_events(tmp_path / "e.txt", EVENTS)
    (tmp_path / "bad.jsonl").write_text('{"kind": "flying"}\n')
    with pytest.raises(LaneFinderError, match="not an event"):
        read_events(tmp_path / "bad.jsonl")
    with pytest.raises(LaneFinderError, match="not found"):
        read_events(tmp_path / "none.csv")


# -- synthetic truth -----------------------------------------------------------------------
def truth_rows(name, camera):
    r = Renderer(camera, Mount(), SCENARIOS[name], supersample=1)
    n = round(SCENARIOS[name].duration_s * FPS)
    out = []
    for i in range(n):
        tr = r.truth(i, i / FPS, r.geometry(i / FPS))
        out.append({"frame": i, "time_s": tr.time_s, "state": "tracking", "offset_m": tr.offset_m,
                    "width_m": tr.width_m})
    return out


@pytest.fixture(scope="module")
def small_camera():
    return CameraModel.ideal((320, 180))


def test_the_lane_change_scenario_switches_the_ego_lane(small_camera):
    sc = SCENARIOS["lane-change"]
    r = Renderer(small_camera, Mount(), sc, supersample=1)
    before, during, after = (r.truth(0, t, r.geometry(t)) for t in (1.0, 3.9, 7.0))
    assert r.ego_lane(r.geometry(1.0)) == 0 and r.ego_lane(r.geometry(7.0)) == 1
    assert abs(before.offset_m) < 0.1 and abs(after.offset_m) < 0.1  # in the middle of each lane
    assert during.offset_m < 0  # just past the dashed line: the new lane's centre is to the right
    # The ego lane's left line is the yellow line before and the dashed white line after: look
    # at the paint under the truth's left line in the near rows.
    for truth, t, yellow in ((before, 1.0, True), (after, 7.0, False)):
        hsv = cv2.cvtColor(r.render(t), cv2.COLOR_BGR2HSV)
        paint = [hsv[y, round(x)] for x, y in zip(truth.left_x, truth.h_samples, strict=True) if x >= 0 and y > 120]
        painted = [(int(s), int(v)) for _h, s, v in paint if v > 150]
        assert painted, (t, paint)
        assert all((s > 100) == yellow for s, _v in painted), (t, painted)


def test_true_events_of_the_scenarios(small_camera):
    changes = detect_events(truth_rows("lane-change", small_camera), FPS)
    assert kinds(changes) == ["lane-change-right", "lane-change-left"]
    assert changes[0].start_s == pytest.approx(2.0, abs=0.1) and changes[1].start_s == pytest.approx(8.5, abs=0.1)
    assert all(e.end_s - e.start_s < 3.6 for e in changes)
    drift = detect_events(truth_rows("drift", small_camera), FPS)
    assert kinds(drift) == ["departure-left", "departure-right"]  # and the near misses give none
    assert all(-0.32 < e.min_distance_m < -0.1 for e in drift)
    assert all(0.3 < e.lateral_speed_mps < 1.0 for e in drift)


def test_existing_scenarios_have_no_manoeuvres():
    for name in ("straight", "curve", "shadows", "pavement", "glare", "worn", "double-yellow", "sharp-curve"):
        assert SCENARIOS[name].manoeuvres == () and SCENARIOS[name].duration_s == 0.0


# -- through the pipeline ------------------------------------------------------------------
# One change to the right over 3 s, rendered small (640x360) to keep it short.
QUICK_CHANGE = Scenario("quick-change", offset_m=(0.0, 0.03), heading=(0.0, 0.002), curvature=(1 / 1000, 0.0),
                        width_m=(3.7, 0.03), manoeuvres=((1.0, 3.0, 3.7),))


@pytest.fixture(scope="module")
def change_sequence(tmp_path_factory):
    folder = tmp_path_factory.mktemp("quick-change")
    return write_sequence(QUICK_CHANGE, round(QUICK_CHANGE.duration_s * FPS), folder, seed=5,
                          camera=udacity_camera().scaled_to((640, 360)))


@pytest.mark.slow
def test_the_pipeline_finds_a_synthetic_lane_change(change_sequence):
    from lanefinder.config import load_config
    from lanefinder.telemetry import read_telemetry
    from lanefinder.videojob import process_video

    (truth,) = read_events(change_sequence / "events_gt.jsonl")
    assert truth["kind"] == "lane-change-right"
    tel = change_sequence / "t.jsonl"
    process_video(change_sequence / "video.mp4", None, load_config(change_sequence / "config.toml"), telemetry=tel,
                  progress=False)
    found = detect_events(read_telemetry(tel), FPS)
    changes = [e for e in found if e.kind.startswith("lane-change")]
    assert kinds(changes) == ["lane-change-right"]
    # Measured (seed 5): start and end each 0.04 s (one frame) after the truth's.
    assert abs(changes[0].start_s - truth["start_s"]) <= 0.1
    assert abs(changes[0].end_s - truth["end_s"]) <= 0.1


@pytest.mark.slow
def test_video_command_writes_events(change_sequence, tmp_path):
    video = str(change_sequence / "video.mp4")
    opts = ["-c", str(change_sequence / "config.toml"), "--quiet"]
    p = run_lanefinder("video", video, *opts, "--telemetry",
                       str(tmp_path / "t.csv"), "--events", str(tmp_path / "e.csv"), timeout=300)
    assert p.returncode == 0, p.stderr
    assert "events: departure-left 0, departure-right 0, lane-change-left 0, lane-change-right 1" in p.stdout
    assert [e["kind"] for e in read_events(tmp_path / "e.csv") if e["kind"] != "lost"] == ["lane-change-right"]
    # Names are checked before the run: a bad suffix, another output, the input itself.
    src = tmp_path / "in.csv"
    shutil.copy(video, src)
    cases = [([video, "--events", str(tmp_path / "e.txt")], "must end in .csv, .jsonl or .parquet"),
             ([video, "--events", str(tmp_path / "t2.csv"), "--telemetry", str(tmp_path / "t2.csv")], "two outputs"),
             ([str(src), "--events", str(src), "--telemetry", str(tmp_path / "u.csv")], "overwrite the input")]
    for args, needle in cases:
        p = run_lanefinder("video", *args, *opts,
                           timeout=300)
        assert p.returncode == 2 and "Traceback" not in p.stderr, p.stderr
        assert len(p.stderr.strip().splitlines()) == 1 and needle in p.stderr, p.stderr
    assert not (tmp_path / "u.csv").exists() and not (tmp_path / "t2.csv").exists()
    assert src.read_bytes() == (change_sequence / "video.mp4").read_bytes()


@pytest.mark.slow
def test_video_command_with_events_alone(change_sequence, tmp_path):
    p = run_lanefinder("video", str(change_sequence / "video.mp4"), "-c", str(change_sequence / "config.toml"),
                       "--quiet", "--events", str(tmp_path / "e.parquet"), timeout=300)
    assert p.returncode == 0, p.stderr
    assert [e["kind"] for e in read_events(tmp_path / "e.parquet") if e["kind"] != "lost"] == ["lane-change-right"]
    assert sorted(f.name for f in tmp_path.iterdir()) == ["e.parquet"]

"""The TuSimple metric and the metre errors, against hand-computed cases."""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest

from lanefinder.errors import LaneFinderError
from lanefinder.evaluate import (
    bench_frame,
    evaluate,
    lane_angle,
    line_accuracy,
    read_ground_truth,
    read_predictions,
)

Y = list(range(400, 720, 10))  # 32 rows


def vertical(x: float, first: int = 0) -> list[float]:
    return [-2.0] * first + [float(x)] * (32 - first)


def test_point_threshold_is_20_px_over_cos_angle():
    # A lane leaning 45 degrees: x = y - 100; the threshold becomes 20/cos(45) = 28.28 px.
    gt = np.array([y - 100.0 for y in Y])
    assert lane_angle(gt, np.array(Y)) == pytest.approx(math.pi / 4)
    assert line_accuracy(gt + 28.0, gt, 20 / math.cos(math.pi / 4)) == 1.0
    assert line_accuracy(gt + 28.5, gt, 20 / math.cos(math.pi / 4)) == 0.0
    # Vertical: 19.9 px passes, 20 px does not (strictly less than).
    v = np.array(vertical(300))
    assert line_accuracy(v + 19.9, v, 20.0) == 1.0 and line_accuracy(v + 20.0, v, 20.0) == 0.0


def test_points_missing_in_both_count_as_correct():
    gt = vertical(300, first=8)  # 8 absent rows, 24 present
    pred = vertical(300, first=8)
    assert line_accuracy(np.array(pred), np.array(gt), 20) == 1.0
    # Predicting the absent rows too makes them wrong: 24/32.
    assert line_accuracy(np.array(vertical(300)), np.array(gt), 20) == pytest.approx(24 / 32)


def test_lane_matches_at_85_percent():
    gt = vertical(300)
    pred_ok = [300.0] * 28 + [400.0] * 4  # 28/32 = 0.875
    pred_bad = [300.0] * 27 + [400.0] * 5  # 27/32 = 0.844
    assert bench_frame([pred_ok], [gt], Y) == pytest.approx((0.875, 0.0, 0.0))
    acc, fp, fn = bench_frame([pred_bad], [gt], Y)
    assert acc == pytest.approx(27 / 32) and fp == 1.0 and fn == 1.0


def test_fp_and_fn_counts():
    gts = [vertical(300), vertical(600)]
    # One good prediction, one far off: 1 matched, FP 1/2, FN 1/2, accuracy (1 + 0)/2.
    acc, fp, fn = bench_frame([vertical(300), vertical(900)], gts, Y)
    assert (acc, fp, fn) == pytest.approx((0.5, 0.5, 0.5))
    # No predictions: accuracy 0, FP 0 (nothing predicted), FN 1.
    assert bench_frame([], gts, Y) == (0.0, 0.0, 1.0)


def test_more_than_four_truth_lanes_forgive_one_miss_and_drop_the_worst():
    gts = [vertical(x) for x in (100, 300, 500, 700, 900)]
    preds = [vertical(x) for x in (100, 300, 500, 700)]  # the 5th is missed
    acc, fp, fn = bench_frame(preds, gts, Y)
    assert acc == 1.0 and fp == 0.0 and fn == 0.0


def test_too_many_predictions_or_too_slow_scores_zero():
    gts = [vertical(300)]
    preds = [vertical(x) for x in (300, 500, 700, 900)]  # 4 > 1 + 2
    assert bench_frame(preds, gts, Y) == (0.0, 0.0, 1.0)
    assert bench_frame([vertical(300)], gts, Y, running_time_ms=250) == (0.0, 0.0, 1.0)


def test_wrong_number_of_points_is_a_format_error():
    from lanefinder.errors import LaneFinderError

    with pytest.raises(LaneFinderError):
        bench_frame([[300.0] * 10], [vertical(300)], Y)


def test_dataset_figures_and_metre_errors():
    gt = {
        f"frame/{i:06d}": {"lanes": [vertical(300), vertical(600)], "h_samples": Y, "offset_m": 0.1,
                           "curvature_per_m": 1e-3, "radius_m": 1000.0 if i else 500.0}
        for i in range(4)
    }
    pred = {
        "frame/000000": {"lanes": [vertical(305), vertical(598)], "offset_m": 0.12, "curvature_per_m": 1.5e-3,
                         "radius_m": 600.0},
        "frame/000001": {"lanes": [vertical(300), vertical(600)], "offset_m": 0.1, "curvature_per_m": 1e-3,
                         "radius_m": 1000.0},
        "frame/000002": {"lanes": [vertical(300), vertical(700)], "offset_m": 0.8, "curvature_per_m": 1e-3,
                         "radius_m": 1000.0},
        # frame 3 missing
    }
    r = evaluate(gt, pred)
    assert r.frames == 4 and r.missing_frames == 1
    # Accuracies 1, 1, 0.5, 0 -> 0.625; FP 0, 0, 0.5, 0 -> 0.125; FN 0, 0, 0.5, 1 -> 0.375.
    assert r.accuracy == pytest.approx(0.625) and r.fp == pytest.approx(0.125) and r.fn == pytest.approx(0.375)
    # Offset errors 0.02, 0, 0.7 -> median 0.02.
    assert r.offset_err_median_m == pytest.approx(0.02)
    assert r.curvature_err_median == pytest.approx(0.0)
    # Relative radius error only where R < 1 km: frame 0, |600 - 500| / 500.
    assert r.radius_rel_err_median == pytest.approx(0.2)
    # Catastrophic: frame 2 (100 px line error, 0.7 m offset error) and frame 3 (missing).
    assert r.catastrophic_rate == pytest.approx(0.5)


def test_a_frame_with_no_visible_paint_counts_only_what_is_shown():
    rows = [700, 710]
    gt = {"a": {"lanes": [[100, 101]], "h_samples": rows}, "b": {"lanes": [], "h_samples": rows}}
    hit = {"lanes": [[100, 101]], "h_samples": rows}
    shown = evaluate(gt, {"a": hit, "b": hit})
    assert shown.accuracy == 1.0 and shown.fp == 0.5 and shown.catastrophic_rate == 0.0
    none = evaluate(gt, {"a": hit, "b": {"lanes": [], "h_samples": rows}})
    assert none.accuracy == 1.0 and none.fp == 0.0 and none.no_lane_rate == 0.0


def test_the_lateral_error_leaves_out_a_line_without_paint():
    # A bare road edge on the left: the truth places the lane's left boundary (x 300 at the 6 m row)
    # but has no paint to label there; the prediction's left line sits on the asphalt edge, 40 px off.
    rows = [600, 700]
    lateral = {"6": {"y": 650.0, "m_per_px": 0.01, "x": [300.0, 900.0]}}
    gt = {"a": {"lanes": [[850.0, 950.0]], "h_samples": rows, "left_x": [-2.0, -2.0], "right_x": [850.0, 950.0],
                "lateral": lateral}}
    pred = {"a": {"lanes": [[210.0, 310.0], [852.0, 952.0]], "h_samples": rows}}
    assert evaluate(gt, pred).lateral_err_6m_p90 == pytest.approx(0.02)
    # Painted on both sides, the same left line counts (0.40 m off).
    gt["a"] = {**gt["a"], "lanes": [[250.0, 350.0], [850.0, 950.0]], "left_x": [250.0, 350.0]}
    assert evaluate(gt, pred).lateral_err_6m_median == pytest.approx(0.21)


def test_rows_that_cannot_be_scored_are_one_error(tmp_path):
    row = {"frame": 0, "h_samples": [700], "left_x": [300.0], "right_x": [900.0]}
    (tmp_path / "gt.jsonl").write_text(json.dumps({**row, "radius_m": 0}) + "\n")  # was a division by zero
    with pytest.raises(LaneFinderError, match="row 1: radius_m is 0"):
        read_ground_truth(tmp_path / "gt.jsonl")
    (tmp_path / "p.jsonl").write_text(json.dumps({k: v for k, v in row.items() if k != "left_x"}) + "\n")
    with pytest.raises(LaneFinderError, match="no left_x"):  # was scored as if the line were never shown
        read_predictions(tmp_path / "p.jsonl")
    (tmp_path / "p.jsonl").write_text(json.dumps({**row, "left_x": "300"}) + "\n")
    with pytest.raises(LaneFinderError, match="left_x must be a list of numbers"):
        read_predictions(tmp_path / "p.jsonl")


_ROWS = [160, 170, 180, 190, 200]


@pytest.mark.parametrize(("change", "says"), [
    ({"frame": "abc"}, "frame must be a whole number"),
    ({"frame": 1.7}, "frame must be a whole number"),  # was matched as frame 1
    ({"frame": None}, "frame must be a whole number"),
    ({"row_distance_m": 5}, "row_distance_m must be a list of numbers"),
    ({"row_distance_m": ["a"] * 5}, "row_distance_m must be a list of numbers"),
    ({"lateral": 5}, "lateral must map distances"),
    ({"lateral": {"6": {"x": [1]}}}, "lateral must map distances"),
    ({"left_x": 5}, "left_x must be a list of numbers"),
    ({"h_samples": [200] * 5}, "h_samples must be rows from top to bottom"),
    ({"offset_m": 1e308}, "offset_m is not a number within"),
    ({"lanes": [[10 ** 400, 20, 30, 40, 50]]}, "lanes must be lists of numbers"),  # was an OverflowError
])
def test_truth_rows_with_fields_of_the_wrong_kind_are_one_error(tmp_path, change, says):
    # A bad-input campaign: each of these was an internal error (ValueError, TypeError, KeyError,
    # OverflowError), a silent cut or a table of inf and NaN.
    row = {"frame": 1, "lanes": [[10, 20, 30, 40, 50]], "h_samples": _ROWS, **change}
    (tmp_path / "gt.jsonl").write_text(json.dumps(row) + "\n")
    with pytest.raises(LaneFinderError, match=f"row 1: {says}"):
        read_ground_truth(tmp_path / "gt.jsonl")


def test_a_frame_given_twice_is_refused(tmp_path):
    # The last of the two used to win without a word (the truth of the first was lost).
    row = {"raw_file": "a.jpg", "lanes": [[10, 20, 30, 40, 50]], "h_samples": _ROWS}
    (tmp_path / "gt.jsonl").write_text(json.dumps(row) + "\n" + json.dumps(row) + "\n")
    with pytest.raises(LaneFinderError, match=r"row 2: frame 'a\.jpg' is given twice"):
        read_ground_truth(tmp_path / "gt.jsonl")
    (tmp_path / "p.jsonl").write_text(json.dumps(row) + "\n" + json.dumps(row) + "\n")
    with pytest.raises(LaneFinderError, match="given twice"):
        read_predictions(tmp_path / "p.jsonl")


def test_the_rows_of_a_frame_under_72_rows_may_repeat(tmp_path):
    # telemetry.h_samples repeats some of its 32 rows on frames 64-71 rows tall (MIN_FRAME_PX allows 64).
    from lanefinder.telemetry import h_samples

    rows = h_samples(64)
    assert len(set(rows)) < len(rows)
    row = {"frame": 0, "h_samples": rows, "lanes": [[10.0] * len(rows)]}
    (tmp_path / "gt.jsonl").write_text(json.dumps(row) + "\n")
    assert read_ground_truth(tmp_path / "gt.jsonl")["frame/000000"]["h_samples"].tolist() == rows


def test_truth_is_read_a_line_at_a_time_into_shared_arrays(tmp_path):
    # 100,000 TuSimple frames (146 MB) took 2.3 GB and 94 s as lists of Python numbers; as arrays,
    # read a line at a time with the rows shared, 0.6 GB and 60 s, and the same figures
    rows = [{"raw_file": f"clips/{i}.jpg", "h_samples": Y, "lanes": [[300 + i] * len(Y), [-2] * len(Y)]}
            for i in range(3)]
    (tmp_path / "gt.json").write_text("".join(json.dumps(r) + "\n" for r in rows))
    gt = read_ground_truth(tmp_path / "gt.json")
    first, last = gt["clips/0.jpg"], gt["clips/2.jpg"]
    assert first["h_samples"] is last["h_samples"] and first["h_samples"].tolist() == Y
    assert [lane.tolist() for lane in last["lanes"]] == rows[2]["lanes"]
    pred = {k: {"lanes": [lane.tolist()]} for k, lane in ((k, g["lanes"][0]) for k, g in gt.items())}
    assert evaluate(gt, pred).accuracy == 0.5  # (TuSimple: a truth lane of no points still counts, missed)


def test_a_line_that_is_not_utf8_is_named(tmp_path):
    (tmp_path / "gt.jsonl").write_bytes(b'{"frame": 0, "h_samples": [700], "lanes": [[1]]}\n\xff\xfe\n')
    with pytest.raises(LaneFinderError, match=r"gt.jsonl: not JSON Lines \(line 2: not UTF-8 text"):
        read_ground_truth(tmp_path / "gt.jsonl")


@pytest.mark.parametrize(("pred", "gt", "ys", "expected"), [
    # 2.4 px a row: the threshold is 52 px, which np.polyfit gives as 52.00000000000002 (a closed-form
    # slope gave 51.99999999999999 and missed this prediction, 52 px off)
    ([[152, 272]], [[100, 220]], [160, 210], (1.0, 0.0, 0.0)),
    # the truth's points on one repeated row: polyfit still gives a slope (the closed form gave 0)
    ([[120, 130, -2]], [[100, 110, -2]], [700, 700, 710], (1.0, 0.0, 0.0)),
])
def test_the_threshold_is_the_benchmarks_to_the_last_bit(pred, gt, ys, expected):
    assert bench_frame(pred, gt, ys) == expected


def test_a_truth_lane_of_another_length_is_refused():
    with pytest.raises(LaneFinderError, match="every truth lane needs one x per h_sample"):
        bench_frame([[1, 2, 3]], [[5]], [1, 2, 3])


def test_lines_ending_in_cr_alone_are_read(tmp_path):
    row = {"frame": 0, "h_samples": Y, "lanes": [[300.0] * len(Y)]}
    (tmp_path / "gt.jsonl").write_bytes((json.dumps(row) + "\r" + json.dumps({**row, "frame": 1}) + "\r").encode())
    assert sorted(read_ground_truth(tmp_path / "gt.jsonl")) == ["frame/000000", "frame/000001"]


@pytest.mark.parametrize(("text", "needle"), [
    ('{"frame": ' + "9" * 5000 + "}\n", "line 1: a number of more digits than can be read"),
    ("[" * 100_000 + "]" * 100_000 + "\n", "line 1: nested too deeply"),
])
def test_json_that_python_cannot_hold_is_named(tmp_path, text, needle):
    # (both were an internal error: ValueError, RecursionError)
    (tmp_path / "gt.jsonl").write_text(text)
    with pytest.raises(LaneFinderError, match=re.escape(needle)):
        read_ground_truth(tmp_path / "gt.jsonl")


@pytest.mark.parametrize(("name", "frames"), [("project_video", 20), ("challenge_video", 20),
                                              ("harder_challenge_video", 43)])
def test_the_hand_labels_are_read_by_eval(name, frames):
    # data/truth/: `lanefinder eval --gt` reads them; each frame's lines are on the TuSimple rows, left of right
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "data" / "truth" / f"{name}.jsonl"
    gt = read_ground_truth(path)
    assert len(gt) == frames and all(k.startswith("frame/") for k in gt)
    for g in gt.values():
        assert g["h_samples"].tolist() == list(range(400, 720, 10))
        left, right = g["left_x"], g["right_x"]
        both = (left >= 0) & (right >= 0)
        assert (left[both] < right[both]).all()
        assert len(g["lanes"]) == int((left >= 0).any()) + int((right >= 0).any())

"""Accuracy regression per hard condition on the fixed-look synthetic scenes (seed 0, 20 frames).

A file of its own so that `make test`'s two processes share the load (a file runs in one process).
"""

from __future__ import annotations

import pytest

from lanefinder.config import load_config
from lanefinder.evaluate import evaluate, read_ground_truth, read_predictions
from lanefinder.synth import write_sequence
from lanefinder.videojob import process_video

# Measured on 30 frames, seed 0, against the truth that runs as far as each marking is visible
# (not to the end of the bird's-eye view, as before the far field: the accuracies are not
# comparable with the earlier bars); thresholds a little below what was measured. The test runs the
# first 20 of those frames (the same frames, for time): every bar holds there unchanged (measured).
# name: (min accuracy, max median offset error m, max p90 offset error m, max catastrophic rate,
#        min accuracy 40-70 m ahead)
BARS = {
    "straight": (0.995, 0.02, 0.03, 0.0, 0.97),
    "curve": (0.995, 0.02, 0.03, 0.0, 0.98),
    "shadows": (0.995, 0.02, 0.03, 0.0, 0.98),
    "pavement": (0.995, 0.025, 0.04, 0.0, 0.98),
    # Glare: since the truth leaves out paint the glare washes out, the white line's far part is not
    # labelled, and the line shown on to the view's top counts against it (0.809 measured; 0.93 before).
    "glare": (0.79, 0.02, 0.03, 0.0, 0.15),
    "worn": (0.97, 0.02, 0.03, 0.0, 0.65),
    "double-yellow": (0.995, 0.02, 0.03, 0.0, 0.98),
    "sharp-curve": (0.96, 0.025, 0.1, 0.05, 0.57),
    # Crests and sags break the flat road the bird's-eye view assumes (a two-lane road, its solid
    # edge line the ego lane's right line, a cluttered verge): 0.967 measured on these 20 frames
    # (offset error median 0.010 m, p90 0.039 m; 40-70 m 0.73); 0.939 over 30 frames.
    "hills": (0.955, 0.02, 0.05, 0.0, 0.65),
    # Curvature changing along the view (lines that are cubics): 0.9617 measured on these 20 frames
    # (offset error median 0.026 m, p90 0.030 m; 40-70 m 0.81), the same with the far field's cubic
    # test; over 30 frames 0.9714 before that test, 0.9724 with it.
    "winding": (0.955, 0.03, 0.035, 0.0, 0.79),
}


@pytest.mark.slow
@pytest.mark.parametrize("name", list(BARS))
def test_accuracy_regression(name, tmp_path):
    folder = write_sequence(name, 20, tmp_path, seed=0)
    process_video(folder / "video.mp4", None, load_config(folder / "config.toml"),
                  telemetry=folder / "t.jsonl", progress=False)
    rep = evaluate(read_ground_truth(folder / "gt.jsonl"), read_predictions(folder / "t.jsonl"))
    min_acc, max_off, max_off90, max_cat, min_far = BARS[name]
    assert rep.accuracy >= min_acc
    assert rep.band_accuracy["40-70"] >= min_far
    assert rep.offset_err_median_m <= max_off
    assert rep.offset_err_p90_m <= max_off90
    assert rep.catastrophic_rate <= max_cat

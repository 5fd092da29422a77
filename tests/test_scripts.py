"""The measuring scripts refuse bad arguments with one line, before any work.

Each runs as ``python SCRIPT`` in a fork of a process that has imported lanefinder (tests/clirun.py).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from clirun import run_script

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize(("args", "says"), [
    (["--lens-hfov", "500"], "--lens-hfov must be 1-170 degrees"),
    (["--lens-hfov", "90", "--size", "19x"], "--size must be WxH"),
    (["--lens-hfov", "90", "--size", "10x10"], "--size must be WxH"),
    (["--size", "640x"], "--size must be WxH"),
    (["--frames", "0"], "--frames must be at least 1"),
])
def test_eval_synthetic_refuses_a_lens_it_cannot_render(tmp_path, args, says):
    p = run_script(ROOT / "scripts" / "eval_synthetic.py", "--out", str(tmp_path), *args, timeout=60)
    assert p.returncode == 2
    assert says in p.stderr and "Traceback" not in p.stderr
    assert not any(tmp_path.iterdir())  # nothing rendered


@pytest.mark.parametrize(("setup", "says"), [("none", "run `make stills` first"), ("bad", "run `make stills` first"),
                                             ("no default", "run `make stills` first"),
                                             ("exists", "exists: give a new folder")])
def test_stills_pairs_refuses_a_missing_report_or_an_existing_folder(tmp_path, setup, says):
    report, out = tmp_path / "report.json", tmp_path / "pairs"
    if setup == "bad":
        report.write_text('{"project_video": 3}')
    if setup == "no default":
        report.write_text('{"challenge_video": {"per_still": [{"frame": 15}]}}')
    if setup == "exists":
        out.mkdir()
    p = run_script(ROOT / "scripts" / "stills_pairs.py", "--report", str(report), "--out", str(out), timeout=60)
    assert p.returncode == 2 and says in p.stderr and "Traceback" not in p.stderr
    assert out.exists() == (setup == "exists") and len(list(tmp_path.iterdir())) == (setup != "none")


def test_stills_pairs_refuses_a_report_of_other_footage(tmp_path):
    # a still the video does not hold (frame 99999 of a 4-second clip) is refused, not passed over
    (tmp_path / "videos").mkdir()
    (tmp_path / "videos" / "clip.mp4").symlink_to(ROOT / "data" / "clips" / "challenge_3-7s.mp4")
    (tmp_path / "report.json").write_text('{"clip": {"per_still": [{"frame": 99999, "default": '
                                          '{"lane": true, "agrees": false}}]}}')
    p = run_script(ROOT / "scripts" / "stills_pairs.py", "--report", str(tmp_path / "report.json"), "--videos",
                   str(tmp_path / "videos"), "--out", str(tmp_path / "pairs"))
    assert p.returncode == 2 and "holds no frame 99999" in p.stderr and "Traceback" not in p.stderr
    assert not (tmp_path / "pairs").exists() and not list(tmp_path.glob(".pairs*"))


@pytest.mark.slow  # each reads a video
@pytest.mark.parametrize(("args", "says"), [(["nope.mp4"], "video not found: nope.mp4"),
                                            (["data/clips/project_37-47s.mp4", "--first", "5", "--last", "2"],
                                             "0 <= first <= last"),
                                            (["data/clips/project_37-47s.mp4", "--first", "9999", "--last", "9999"],
                                             "has no frame 9999")])
def test_selfcal_frames_refuses_bad_arguments_with_one_line(args, says):
    p = run_script(ROOT / "scripts" / "selfcal_frames.py", *args, timeout=60, cwd=ROOT)
    assert p.returncode == 2 and says in p.stderr and "Traceback" not in p.stderr


@pytest.mark.slow
def test_selfcal_frames_keeps_the_project_clips_set_up():
    # The default set-up is right for the project video: an estimate on its first frames confirms it.
    p = run_script(ROOT / "scripts" / "selfcal_frames.py", "data/clips/project_37-47s.mp4", "--last", "8", timeout=60,
                   cwd=ROOT)
    assert p.returncode == 0, p.stderr
    assert "an estimate on 4 frames: horizon row 41" in p.stdout and "confirms the set-up in use" in p.stdout
    assert "(+0.0 px), 0 changes" in p.stdout

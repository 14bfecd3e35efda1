"""Errors are Python exceptions, one class per kind, carrying the command
line's one-line messages, and nothing is left half-written."""

import io
import json
import re
import shutil

import pytest

import eyereplay
from conftest import DATA, run_cli, small_config


def test_missing_video_is_a_video_error(tmp_path):
    with pytest.raises(eyereplay.VideoError) as e:
        eyereplay.extract(tmp_path / "nope.mp4", progress=False)
    assert "nope.mp4" in str(e.value) and "\n" not in str(e.value)
    r = run_cli("extract", tmp_path / "nope.mp4", "--out", tmp_path / "x.csv")
    assert str(e.value) in r.stderr


def test_not_a_video_is_a_video_error(tmp_path):
    p = tmp_path / "fake.mp4"
    p.write_bytes(b"this is not a video" * 100)
    with pytest.raises(eyereplay.VideoError):
        eyereplay.extract(p, out=tmp_path / "fake.csv", progress=False)
    assert not (tmp_path / "fake.csv").exists()


def test_unknown_device_is_a_config_error_and_cpu_is_the_default(tmp_path):
    import inspect

    with pytest.raises(eyereplay.ConfigError) as e:
        eyereplay.extract(DATA / "franck.mp4", device="gpu", progress=False)
    assert "'gpu'" in str(e.value) and "\n" not in str(e.value)
    for f in (eyereplay.extract, eyereplay.extract_many):
        assert inspect.signature(f).parameters["device"].default == "cpu"


def test_out_of_range_options_name_themselves(tmp_path):
    # Refused before the video is opened, as the command line refuses them.
    video = DATA / "franck.mp4"
    for kwargs, name in (
        ({"blink_ratio": 5.0}, "blink_ratio"),
        ({"blink_ratio": float("nan")}, "blink_ratio"),
        ({"blink_ratio": -1.0}, "blink_ratio"),
        ({"max_seconds": 0}, "max_seconds"),
        ({"max_seconds": -1.0}, "max_seconds"),
        ({"threads": -1}, "threads"),
        ({"iris_views": -3}, "iris_views"),
    ):
        with pytest.raises(eyereplay.ConfigError) as e:
            eyereplay.extract(video, out=tmp_path / "x.csv", progress=False, **kwargs)
        assert name in str(e.value) and "\n" not in str(e.value), kwargs
    assert not (tmp_path / "x.csv").exists()
    # One path where a list is wanted, and the other way round.
    with pytest.raises(TypeError, match="list of paths"):
        eyereplay.extract_many(str(video), progress=False)
    with pytest.raises(TypeError, match="extract_many"):
        eyereplay.extract([str(video)], progress=False)


def test_missing_models_is_a_model_error(tmp_path):
    with pytest.raises(eyereplay.ModelError) as e:
        eyereplay.extract(DATA / "franck.mp4", models=tmp_path, progress=False)
    assert str(tmp_path) in str(e.value)
    assert issubclass(eyereplay.ModelError, eyereplay.EyereplayError)


def test_missing_source_is_a_source_error(tmp_path):
    cfg = small_config()
    cfg["classes"]["reading"]["sources"][0]["path"] = str(tmp_path / "gone.csv")
    with pytest.raises(eyereplay.SourceError) as e:
        eyereplay.prepare(cfg, tmp_path / "out", progress=False)
    assert "gone.csv" in str(e.value)
    assert not (tmp_path / "out").exists()


def test_bad_render_setting_is_a_config_error(tmp_path):
    cfg = small_config()
    cfg["render"]["crf"] = "high"
    with pytest.raises(eyereplay.ConfigError) as e:
        eyereplay.generate(cfg, tmp_path / "out", progress=False)
    assert "crf" in str(e.value)


def test_none_in_a_dict_is_named(tmp_path):
    cfg = small_config()
    cfg["seed"] = None
    with pytest.raises(eyereplay.ConfigError) as e:
        eyereplay.prepare(cfg, tmp_path / "out", progress=False)
    assert "None" in str(e.value)


def test_config_of_the_wrong_type():
    with pytest.raises(eyereplay.ConfigError):
        eyereplay.prepare(42, None, progress=False)


def test_dataset_of_another_version_is_a_dataset_error(tmp_path):
    cfg = small_config()
    out = tmp_path / "ds"
    eyereplay.prepare(cfg, out, progress=False)
    meta = json.loads((out / "metadata.json").read_text())
    meta["format_version"] = 99
    (out / "metadata.json").write_text(json.dumps(meta))
    with pytest.raises(eyereplay.DatasetError) as e:
        eyereplay.load_dataset(out)
    assert "99" in str(e.value) and "metadata.json" in str(e.value)


def test_prepare_writes_what_the_cli_writes(tmp_path, cache_dir):
    from conftest import to_toml

    cfg = small_config()
    p = tmp_path / "c.toml"
    p.write_text(to_toml(cfg))
    r = run_cli("prepare", "--config", p, "--out", tmp_path / "cli", "--cache", cache_dir)
    assert r.returncode == 0, r.stderr
    s = eyereplay.prepare(p, tmp_path / "py", cache=cache_dir, progress=False)
    for name in ("labels.csv", "metadata.json", "reading/reading_0001.csv", "pool/conversation.csv"):
        assert (tmp_path / "py" / name).read_bytes() == (tmp_path / "cli" / name).read_bytes()
    assert set(s["classes"]) == {"reading", "conversation"}
    assert s["classes"]["reading"]["sessions"] == 2
    # calibration as printed by the CLI
    cal = s["calibration"]
    assert f"s = ({cal['s_x']:.1f}, {cal['s_y']:.1f})" in r.stdout


def test_one_csv_for_two_videos_is_refused_before_work(tmp_path):
    v = DATA / "franck.mp4"
    with pytest.raises(eyereplay.ConfigError) as e:
        eyereplay.extract_many([v, v], out=tmp_path / "both.csv", progress=False)
    assert "one file but 2 videos" in str(e.value)
    r = run_cli("extract", v, v, "--out", tmp_path / "both.csv")
    assert str(e.value) in r.stderr
    assert not (tmp_path / "both.csv").exists()


def test_bad_frames_are_config_errors():
    import numpy as np

    f = np.zeros((3, 32, 32, 3), dtype=np.uint8)
    cases = [
        (dict(video=f), "exactly one of fps= and timestamps="),
        (dict(video=f, fps=25, timestamps=[0, 1, 2]), "exactly one of"),
        (dict(video=f, timestamps=[0, 2, 1]), "increasing"),
        (dict(video=f, timestamps=[0, 1]), "2 values for 3 frames"),
        (dict(video=f.astype(np.float32), fps=25), "uint8"),
        (dict(video=f[..., :2], fps=25), "(T, H, W, 3)"),
        (dict(video=f, fps=0), "positive"),
        (dict(video=DATA / "franck.mp4", fps=25), "frames in memory"),
    ]
    for kw, want in cases:
        with pytest.raises(eyereplay.ConfigError) as e:
            eyereplay.extract(progress=False, **kw)
        assert want in str(e.value), (kw, str(e.value))
        assert "\n" not in str(e.value)


def test_detect_on_too_few_frames_names_the_frames_not_a_temporary_file():
    import subprocess

    import numpy as np

    raw = subprocess.run(
        ["ffmpeg", "-v", "error", "-i", str(DATA / "franck.mp4"), "-frames:v", "12",
         "-f", "rawvideo", "-pix_fmt", "rgb24", "-"],
        check=True, capture_output=True,
    ).stdout
    frames = np.frombuffer(raw, dtype=np.uint8).reshape(12, 288, 360, 3)
    with pytest.raises(eyereplay.EyereplayError) as e:
        eyereplay.detect(frames, fps=24, progress=False)
    msg = str(e.value)
    assert msg.startswith("frames: ") and "not enough gaze" in msg, msg
    assert "eyereplay-detect-" not in msg and "\n" not in msg


def test_detect_errors_name_what_is_at_fault_by_class(tmp_path):
    session = tmp_path / "s.csv"
    session.write_text("frame,x,y\n" + "".join(f"{k},640,360\n" for k in range(30)))
    # The detector file: missing, or not a detector.
    with pytest.raises(eyereplay.ModelError, match="not found"):
        eyereplay.detect(session, model=tmp_path / "none.json", progress=False)
    bad = tmp_path / "bad.json"
    bad.write_text('{"kind": "svm"}')
    with pytest.raises(eyereplay.ModelError) as e:
        eyereplay.detect(session, model=bad, progress=False)
    assert str(e.value).startswith(str(bad)) and "\n" not in str(e.value)
    # The input: a CSV of no kind detect reads is a source; a video that
    # is not one, a video.
    other = tmp_path / "other.csv"
    other.write_text("a,b\n1,2\n")
    with pytest.raises(eyereplay.SourceError, match="header: a,b"):
        eyereplay.detect(other, progress=False)
    fake = tmp_path / "fake.mp4"
    fake.write_bytes(b"not a video")
    with pytest.raises(eyereplay.VideoError, match="fake.mp4"):
        eyereplay.detect(fake, progress=False)
    with pytest.raises(eyereplay.VideoError, match="no such file"):
        eyereplay.detect(tmp_path / "gone.mp4", progress=False)


def test_progress_must_be_a_flag_or_an_object_with_its_methods(tmp_path):
    video = DATA / "franck.mp4"
    # Refused before any work, naming what it takes.
    for bad in ("yes", 1, object()):
        with pytest.raises(TypeError, match="progress: expected True, False, None"):
            eyereplay.extract(video, out=tmp_path / "x.csv", progress=bad)
    assert not (tmp_path / "x.csv").exists()

    # An object with some of the methods gets the events it can take;
    # the rest do nothing (no exception on a worker thread per event).
    class Count:
        frames = 0

        def advance(self, n):
            Count.frames += n

    t = eyereplay.extract(video, max_seconds=1, progress=Count())
    assert 0 < Count.frames and len(t["frame"]) > 0


def test_fps_true_is_not_one_frame_a_second():
    import numpy as np

    frames = np.zeros((2, 8, 8, 3), dtype=np.uint8)
    with pytest.raises(eyereplay.ConfigError, match="fps True"):
        eyereplay.extract(frames, fps=True, progress=False)


def _cut_video(tmp_path):
    """An 8-s clip of franck.mp4 cut off half-way through its bytes."""
    import subprocess

    whole = tmp_path / "whole.mp4"
    subprocess.run(
        ["ffmpeg", "-v", "error", "-i", str(DATA / "franck.mp4"), "-t", "8", "-c", "copy",
         "-movflags", "+faststart", str(whole)],
        check=True,
    )
    cut = tmp_path / "cut.mp4"
    cut.write_bytes(whole.read_bytes()[: whole.stat().st_size // 2])
    return cut


def test_a_video_cut_off_part_way_warns_with_its_name(tmp_path):
    cut = _cut_video(tmp_path)
    with pytest.warns(eyereplay.EyereplayWarning) as said:
        t = eyereplay.extract(cut, progress=False)
    # The cut may also leave a corrupt packet, its own warning.
    pattern = r"cut\.mp4: the frames end at [0-9.]+ s of the 8\.[0-5] s"
    assert any(re.search(pattern, str(w.message)) for w in said), [str(w.message) for w in said]
    assert 0 < len(t["frame"]) < 8 * 24
    # Said from the library's worker thread, named at the caller's line
    # (warnings.warn alone would have named "sys:1").
    assert {w.filename for w in said} == {__file__}, [(w.filename, w.lineno) for w in said]
    with pytest.warns(eyereplay.EyereplayWarning) as said:
        eyereplay.extract(cut, progress=eyereplay.ProgressBar(stream=io.StringIO()))
    assert {w.filename for w in said} == {__file__}, [(w.filename, w.lineno) for w in said]


def test_frames_out_of_range_are_named_not_empty_or_shifted(tmp_path):
    # The last generated dataset of the pipeline tests is not at hand here:
    # decode_frames reads any video, franck.mp4 (4800 frames) will do.
    from eyereplay.dataset import decode_frames

    video = DATA / "franck.mp4"
    assert decode_frames(video, 10, 2).shape == (2, 288, 360, 3)
    for kw, want in [
        (dict(start=-5, count=2), "start -5"),
        (dict(start=0, count=-3), "count -3"),
        (dict(start=1.5, count=2), "start 1.5"),
        (dict(start=True, count=2), "start True"),
    ]:
        with pytest.raises(ValueError, match=want):
            decode_frames(video, **kw)
    with pytest.raises(eyereplay.VideoError, match="frame 99999 is past its last frame"):
        decode_frames(video, 99999, 2)
    assert decode_frames(video, 0, 0).shape[0] == 0
    # A count that runs past the end (frames 4795-4799 are the last five)
    # is named, not cut short: a batch would change shape downstream.
    assert decode_frames(video, 4795, 5).shape[0] == 5
    with pytest.raises(eyereplay.VideoError, match="ends 5 frames later"):
        decode_frames(video, 4795, 20)


def test_read_csv_of_a_binary_file_names_it_and_a_bom_is_no_column(tmp_path):
    p = tmp_path / "clip.mp4"
    p.write_bytes(b"\x00\x00\x00\x18ftypmp42\xff\xfe\x80" * 10)
    with pytest.raises(ValueError) as e:
        eyereplay.read_csv(p)
    assert str(e.value).startswith(f"{p}: not text"), str(e.value)
    q = tmp_path / "bom.csv"
    q.write_text("\ufeffframe,x,y\n0,1.5,2\n", encoding="utf-8")
    t = eyereplay.read_csv(q)
    assert t.dtype.names == ("frame", "x", "y")
    assert t["x"][0] == 1.5


def test_config_is_not_a_class_to_make():
    # A type alias of what config arguments take, not a constructor that
    # fails with "Cannot instantiate typing.Union".
    assert not hasattr(eyereplay, "Config")


@pytest.mark.skipif(
    "EYEREPLAY_ORT_LIB" in __import__("os").environ,
    reason="a runtime library of the user's may have CUDA",
)
def test_cuda_asked_for_and_not_used_is_said():
    # The pinned library is a CPU build: the networks run on the CPU, and
    # the script is told, as the command tells its user on stderr.
    with pytest.warns(eyereplay.EyereplayWarning, match="CUDA not used"):
        eyereplay.extract(DATA / "franck.mp4", device="cuda", max_seconds=1, progress=False)


def test_a_cut_off_video_warns_without_a_bar_and_from_the_cache(tmp_path):
    # Found by a user's-eye audit (30 Nov 2026): with progress=False the
    # warning was dropped, and a second call, its extraction cached, said
    # nothing; prepare's summary listed none.
    cut = _cut_video(tmp_path)
    said_of = lambda ws: [str(w.message) for w in ws if "the frames end at" in str(w.message)]
    for call in ("extracted", "cached"):
        with pytest.warns(eyereplay.EyereplayWarning) as said:
            eyereplay.detect(cut, progress=False, cache=tmp_path / "cache")
        assert said_of(said) and "cut.mp4" in said_of(said)[0], (call, [str(w.message) for w in said])
    cfg = small_config()
    cfg["classes"]["conversation"]["sources"] = [{"format": "video", "path": str(cut)}]
    with pytest.warns(eyereplay.EyereplayWarning):
        summary = eyereplay.prepare(cfg, None, progress=False)
    assert any("the frames end at" in w for w in summary["warnings"]), summary["warnings"]


def test_frames_and_the_video_they_came_from_get_one_answer(tmp_path):
    import subprocess

    from eyereplay.dataset import decode_frames

    # Lossless RGB, so that the frames in memory are the video's pixels.
    clip = tmp_path / "clip.mkv"
    subprocess.run(
        ["ffmpeg", "-v", "error", "-i", str(DATA / "franck.mp4"), "-t", "12", "-c:v",
         "libx264rgb", "-qp", "0", "-pix_fmt", "rgb24", str(clip)],
        check=True,
    )
    frames = decode_frames(clip)
    from_video = eyereplay.detect(clip, progress=False, cache=tmp_path / "cache")
    from_frames = eyereplay.detect(frames, fps=25, progress=False)
    assert from_frames["input"]["kind"] == "frames"
    assert from_frames["reading_probability"] == from_video["reading_probability"]
    assert list(from_frames["windows"]["reading_probability"]) == list(
        from_video["windows"]["reading_probability"]
    )


def test_frames_refuse_what_does_not_apply_and_a_faceless_clip(tmp_path):
    import numpy as np

    f = np.zeros((5, 90, 160, 3), dtype=np.uint8)
    with pytest.raises(eyereplay.VideoError, match="no face found in any of their 5 frames"):
        eyereplay.extract(f, fps=25, progress=False)
    (tmp_path / "d").mkdir()
    for kw, want in [
        (dict(max_seconds=1), "max_seconds applies to a video file"),
        (dict(threads=2), "threads applies to video files"),
        (dict(threads="x"), "threads 'x'"),
        (dict(out=tmp_path / "d"), "name it with .csv"),
        (dict(out=tmp_path / "f.txt"), "name it with .csv"),
    ]:
        with pytest.raises(eyereplay.ConfigError, match=want):
            eyereplay.extract(f, fps=25, progress=False, **kw)


def test_a_config_dict_takes_numpy_numbers_and_names_bad_values(tmp_path):
    import numpy as np

    cfg = small_config()
    plain = eyereplay.prepare(cfg, None, progress=False)
    cfg["seed"] = np.int64(7)
    cfg["smoothing"]["sigma_s"] = np.float32(0.2).item()
    assert eyereplay.prepare(cfg, None, progress=False)["classes"] == plain["classes"]
    cfg = small_config()
    cfg["smoothing"]["sigma_s"] = float("nan")
    with pytest.raises(eyereplay.ConfigError, match=r"smoothing\.sigma_s: nan is not a finite number"):
        eyereplay.prepare(cfg, None, progress=False)
    cfg = small_config()
    cfg["session_frames"] = "50"
    with pytest.raises(eyereplay.ConfigError) as e:
        eyereplay.prepare(cfg, None, progress=False)
    assert "session_frames: invalid type" in str(e.value) and "a whole number" in str(e.value)
    with pytest.raises(TypeError, match="dataset_dir: expected a folder path"):
        eyereplay.load_dataset([tmp_path])
    with pytest.raises(TypeError, match="video_or_frames: expected one path"):
        eyereplay.detect([tmp_path / "a.mp4"])


def test_an_output_folder_that_cannot_be_made_is_a_dataset_error(tmp_path):
    (tmp_path / "afile").write_text("x")
    with pytest.raises(eyereplay.DatasetError, match="afile"):
        eyereplay.generate(small_config(), tmp_path / "afile" / "sub", progress=False)
    with pytest.raises(eyereplay.DatasetError):
        eyereplay.merge(tmp_path / "afile")


def test_numpy_integers_are_whole_numbers(tmp_path):
    import numpy as np

    # What array arithmetic gives: np.int64, not int. Frames of one gray
    # colour (no face) reach the extractor, past the option checks.
    frames = np.full((3, 32, 32, 3), 128, dtype=np.uint8)
    with pytest.raises(eyereplay.VideoError, match="no face"):
        eyereplay.extract(frames, fps=np.int64(24), iris_views=np.int64(1), progress=False)
    with pytest.raises(eyereplay.ConfigError, match="fps"):
        eyereplay.extract(frames, fps=np.int64(0), progress=False)
    with pytest.raises(eyereplay.ConfigError, match="threads"):
        eyereplay.extract(DATA / "franck.mp4", threads=np.float64(1.5), progress=False)
    with pytest.raises(eyereplay.ConfigError, match="threads"):
        eyereplay.extract(DATA / "franck.mp4", threads=np.bool_(True), progress=False)


def test_python_exceptions_catch_ours(tmp_path):
    # A bad option is a ValueError; an input that is not there, a
    # FileNotFoundError of its own class, named as such.
    assert issubclass(eyereplay.ConfigError, ValueError)
    assert issubclass(eyereplay.ConfigError, eyereplay.EyereplayError)
    with pytest.raises(ValueError, match="gpu"):
        eyereplay.extract(DATA / "franck.mp4", device="gpu", progress=False)
    for call, cls, name in (
        (lambda: eyereplay.extract(tmp_path / "nope.mp4", progress=False), eyereplay.VideoError,
         "nope.mp4"),
        (lambda: eyereplay.detect(tmp_path / "nope.csv", progress=False), eyereplay.SourceError,
         "nope.csv"),
        (lambda: eyereplay.prepare(tmp_path / "nope.toml", None, progress=False),
         eyereplay.ConfigError, "nope.toml"),
        (lambda: eyereplay.evaluate(tmp_path / "nodata", progress=False), eyereplay.DatasetError,
         "nodata"),
        (lambda: eyereplay.load_dataset(tmp_path / "nodata"), eyereplay.DatasetError, "nodata"),
    ):
        with pytest.raises(FileNotFoundError) as e:
            call()
        assert isinstance(e.value, cls) and type(e.value).__name__ == cls.__name__
        assert name in str(e.value) and "os error" not in str(e.value)


def test_prepare_checks_the_render_table_as_the_command_does(tmp_path):
    cfg = small_config()
    cfg["render"]["widht"] = 320
    with pytest.raises(eyereplay.ConfigError, match="did you mean 'width'"):
        eyereplay.prepare(cfg, None, dry_run=True, progress=False)
    assert not (tmp_path / "out").exists()


def test_frames_out_in_a_new_folder_is_made_before_the_work(tmp_path):
    import numpy as np

    # As for a video file: the folder is made; and the answer (no face
    # here) comes with nothing half-written in it.
    frames = np.full((3, 32, 32, 3), 128, dtype=np.uint8)
    out = tmp_path / "new" / "a.csv"
    with pytest.raises(eyereplay.VideoError):
        eyereplay.extract(frames, fps=25, out=out, progress=False)
    assert (tmp_path / "new").is_dir() and list((tmp_path / "new").iterdir()) == []


def test_paths_of_every_kind_and_what_is_not_one(tmp_path):
    # Bytes paths (os.listdir(b".")) are paths; a number is named as the
    # argument it was given for.
    with pytest.raises(eyereplay.VideoError, match="nope.mp4"):
        eyereplay.extract(str(tmp_path / "nope.mp4").encode(), progress=False)
    with pytest.raises(TypeError, match="video: expected one path"):
        eyereplay.extract(42, progress=False)
    with pytest.raises(TypeError, match="videos: expected paths, got a int"):
        eyereplay.extract_many([DATA / "franck.mp4", 42], progress=False)


def test_a_progress_object_that_raises_is_reported_once_on_either_path(capfd, monkeypatch):
    import sys

    import numpy as np

    # The work goes on; the first exception is printed as Python prints
    # one it cannot raise, and the object is not called again: the same
    # from a video file (the native side) and from frames (Python's).
    class Broken:
        calls = 0

        def advance(self, n):
            Broken.calls += 1
            raise RuntimeError("boom")

    # The native side reports it as Python reports an exception it cannot
    # raise: through sys.unraisablehook.
    seen = []
    monkeypatch.setattr(sys, "unraisablehook", lambda u: seen.append(str(u.exc_value)))
    t = eyereplay.extract(DATA / "franck.mp4", max_seconds=1, progress=Broken())
    assert len(t["frame"]) > 0 and Broken.calls == 1
    assert seen == ["boom"]
    Broken.calls = 0
    capfd.readouterr()
    frames = np.full((70, 32, 32, 3), 128, dtype=np.uint8)
    with pytest.raises(eyereplay.VideoError, match="no face"):
        eyereplay.extract(frames, fps=25, progress=Broken())
    assert Broken.calls == 1
    err = capfd.readouterr().err
    assert err.count("RuntimeError: boom") == 1, err


def test_a_codec_the_wheel_cannot_decode_is_named(tmp_path):
    import subprocess

    # The wheel's FFmpeg has no AV1 decoder (its README): the error names
    # the codec and the conversion, not FFmpeg's "Decoder not found".
    av1 = tmp_path / "clip.mp4"
    subprocess.run(
        ["ffmpeg", "-v", "error", "-y", "-f", "lavfi", "-i", "testsrc=size=64x48:rate=10",
         "-t", "0.5", "-c:v", "libaom-av1", "-cpu-used", "8", str(av1)],
        check=True,
    )
    with pytest.raises(eyereplay.VideoError, match="no decoder for its av1 video"):
        eyereplay.extract(av1, progress=False)

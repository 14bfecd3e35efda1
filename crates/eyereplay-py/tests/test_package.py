"""The installed package itself: what it links, what it imports, what it
declares."""

import subprocess
import sys
from pathlib import Path

import eyereplay


def test_extension_links_nothing_but_glibc():
    # manylinux: FFmpeg is linked in statically; ONNX Runtime is loaded at
    # run time from the models folder.
    so = next(Path(eyereplay.__file__).parent.glob("_native*.so"))
    out = subprocess.run(["objdump", "-p", str(so)], capture_output=True, text=True, check=True)
    needed = {l.split()[1] for l in out.stdout.splitlines() if l.strip().startswith("NEEDED")}
    allowed = {"libc.so.6", "libm.so.6", "libgcc_s.so.1", "libpthread.so.0", "libdl.so.2",
               "ld-linux-x86-64.so.2", "librt.so.1"}
    assert needed and needed <= allowed, needed - allowed


def test_import_pulls_in_neither_torch_nor_pandas():
    code = "import sys, eyereplay; print('torch' in sys.modules, 'pandas' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False"]


def test_version_is_the_rust_library_version():
    cargo = (Path(__file__).resolve().parents[3] / "Cargo.toml").read_text()
    line = next(l for l in cargo.splitlines() if l.startswith("version = "))
    assert eyereplay.__version__ == line.split('"')[1]


def test_exceptions_form_one_family():
    for cls in (eyereplay.ConfigError, eyereplay.SourceError, eyereplay.VideoError,
                eyereplay.ModelError, eyereplay.DatasetError):
        assert issubclass(cls, eyereplay.EyereplayError)
        assert cls.__doc__
    assert issubclass(eyereplay.EyereplayError, Exception)


def test_public_functions_are_documented():
    for name in eyereplay.__all__:
        obj = getattr(eyereplay, name)
        assert getattr(obj, "__doc__", None), name


def test_the_package_ships_its_models_detector_and_notices():
    m = eyereplay.PACKAGE_MODELS
    for f in ("face_detection_short_range.onnx", "face_landmark.onnx", "iris_landmark.onnx",
              "face_landmark_with_attention.onnx", "face_landmark_with_attention_eyes.onnx",
              "face_landmark.tflite", "iris_landmark.tflite", "face_detection_short_range.tflite",
              "face_landmark_with_attention.tflite",
              "libonnxruntime.so.1.22.1", "NOTICE", "LICENSE-mediapipe", "LICENSE-onnxruntime",
              "ThirdPartyNotices-onnxruntime.txt"):
        assert (m / f).is_file(), f
    assert "Apache" in (m / "LICENSE-mediapipe").read_text()
    assert eyereplay.DEFAULT_DETECTOR.is_file()
    # The full-face mode's mesh and bundled photos, with their licenses.
    f = eyereplay.PACKAGE_FACES
    for name in ("canonical_face_mesh.binarypb", "astronaut.png", "grace_hopper.jpg",
                 "giunchedi.jpg", "kphotoalbum_jesper.jpg", "psychopy_face.jpg",
                 "psychopy_face01.jpg", "NOTICE", "LICENSE-face_mesh.txt",
                 "LICENSE-kphotoalbum.txt", "LICENSE-psychopy.txt"):
        assert (f / name).is_file(), name
    assert "astronaut.png" in (f / "NOTICE").read_text()
    # The shipped networks run (one inference each), from this package.
    lines = eyereplay.check_models(m)
    assert sum("runs" in l for l in lines) >= 3, lines
    # The four .tflite sources and the ONNX Runtime library against their
    # pinned sha256; the five networks against what their conversion recorded.
    assert sum("(pinned, ok)" in l for l in lines) == 5, lines
    assert sum("(as converted, ok)" in l for l in lines) == 5, lines


def _glibc_versions(so):
    out = subprocess.run(["objdump", "-T", str(so)], capture_output=True, text=True, check=True)
    import re

    return {tuple(int(x) for x in v.split(".")) for v in re.findall(r"GLIBC_([0-9.]+)", out.stdout)}


def test_every_shared_library_in_the_wheel_keeps_the_manylinux_2_35_policy():
    # maturin audits the extension when it tags the wheel; the ONNX Runtime
    # library beside the models is checked here the same way: only the
    # policy's system libraries, and no glibc symbol newer than 2.35.
    policy = {"libc.so.6", "libm.so.6", "libgcc_s.so.1", "libpthread.so.0", "libdl.so.2",
              "ld-linux-x86-64.so.2", "librt.so.1", "libstdc++.so.6", "libutil.so.1"}
    pkg = Path(eyereplay.__file__).parent
    libs = list(pkg.glob("_native*.so")) + list((pkg / "models").glob("*.so*"))
    assert len(libs) == 2, libs
    for so in libs:
        out = subprocess.run(["objdump", "-p", str(so)], capture_output=True, text=True, check=True)
        needed = {l.split()[1] for l in out.stdout.splitlines() if l.strip().startswith("NEEDED")}
        assert needed and needed <= policy, (so.name, needed - policy)
        assert max(_glibc_versions(so)) <= (2, 35), so.name


def test_the_type_stubs_declare_every_native_function_and_class():
    # _native.pyi is written by hand: a function added to the extension
    # and not to the stubs is invisible to type checkers and editors.
    import ast

    from eyereplay import _native

    stubs = ast.parse((Path(eyereplay.__file__).parent / "_native.pyi").read_text())
    declared = {n.name for n in stubs.body if isinstance(n, (ast.FunctionDef, ast.ClassDef))}
    native = {k for k in dir(_native) if not k.startswith("_") and callable(getattr(_native, k))}
    assert native == declared, (sorted(native - declared), sorted(declared - native))

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

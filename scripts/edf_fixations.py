#!/usr/bin/env python3
"""EyeLink fixation events (EFIX / ENDFIX) to CSV, standard library only.

  edf_fixations.py unzip WHEEL DIR [MEMBER ...]
      unpack a wheel (a zip) into DIR with zipfile: the listed members, or all
  edf_fixations.py edf WHEEL_DIR FILE.edf OUT.csv [--eye L|R] [--screen WxH]
      read an SR Research EDF file with the EDF API library that the
      eyelinkio wheel bundles (libedfapi/linux/libedfapi.so), through the
      wheel's own ctypes wrapper (eyelinkio/edf/_edf2py.py, _defines.py),
      loaded as plain modules so that eyelinkio/__init__.py (numpy) never runs
  edf_fixations.py asc FILE.asc OUT.csv [--eye L|R] [--screen WxH]
      parse the `EFIX <eye> <start> <end> <dur> <x> <y> <pupil>` lines of an
      EyeLink ASC file

OUT.csv has the header start_ms,end_ms,x,y: tracker clock in ms (EyeLink's
sttime/entime, as printed in ASC files) and the fixation's average gaze
position (gavx/gavy) in screen pixels, sorted by start. Fixations with a
missing position ('.' in ASC, MISSING_DATA 1e8 in EDF, or |x|,|y| >= 1e7) are
dropped. Without --eye the file must be monocular; with it only that eye's
fixations are kept. The CSV is written to a temporary name and renamed.

The screen size is taken from the DISPLAY_COORDS message (GAZE_COORDS when
there is none): `x0 y0 x1 y1` are inclusive pixel bounds, so the width is
x1-x0+1; some experiment scripts write the size itself as x1 (e.g.
`0 0 1920 1080`), which is taken as is when x1-x0 is a common screen width.
--screen WxH makes a mismatch an error. One summary line goes to stdout:
  <name>: fixations=N dropped=N eye=L|R screen=WxH DISPLAY_COORDS=... GAZE_COORDS=...
"""
import csv
import ctypes as ct
import importlib.util
import os
import re
import sys
import zipfile

BAD = 1e7  # edfapi writes MISSING_DATA (1e8) into float fields
EYES = {0: "L", 1: "R", "L": "L", "R": "R"}
COMMON_W = {640, 800, 1024, 1152, 1280, 1366, 1440, 1600, 1680, 1920, 2048, 2560, 3840}


def die(msg):
    print(f"edf_fixations: {msg}", file=sys.stderr)
    sys.exit(1)


def unzip(whl, dest, members):
    with zipfile.ZipFile(whl) as z:
        names = set(z.namelist())
        missing = [m for m in members if m not in names]
        if missing:
            die(f"{whl}: no {', '.join(missing)}")
        z.extractall(dest, members or None)


def load_api(wheel_dir):
    """_edf2py finds the library at Path(__file__).parent.parent.parent /
    'libedfapi/linux/libedfapi.so', i.e. next to the eyelinkio/ folder of
    the unpacked wheel, so loading the module from its own file is enough."""
    os.environ.pop("EYELINKIO_USE_INSTALLED_EDFAPI", None)  # the bundled one
    mods = {}
    for name in ("_defines", "_edf2py"):
        path = os.path.join(wheel_dir, "eyelinkio", "edf", name + ".py")
        spec = importlib.util.spec_from_file_location("eyelinkio_edf_" + name, path)
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        mods[name] = mod
    return mods["_edf2py"], mods["_defines"].event_constants


def read_edf(wheel_dir, path):
    api, ec = load_api(wheel_dir)
    err = ct.c_int(0)
    # consistency_check=2, load events=1, load samples=1; the library printf()s
    # "loadEvents = 1", kept off our stdout (flushed before fd 1 is restored)
    sys.stdout.flush()
    saved = os.dup(1)
    null = os.open(os.devnull, os.O_WRONLY)
    os.dup2(null, 1)
    try:
        fid = api.edf_open_file(os.path.abspath(path).encode(), 2, 1, 1, ct.byref(err))
    finally:
        ct.CDLL(None).fflush(None)
        os.dup2(saved, 1)
        os.close(saved)
        os.close(null)
    if not fid or err.value != 0:
        die(f"cannot open {path}: edf_open_file error {err.value}")
    fix, msgs = [], []
    try:
        while True:
            t = api.edf_get_next_data(fid)
            if t == ec["NO_PENDING_ITEMS"]:
                break
            if t == ec["ENDFIX"]:
                e = api.edf_get_float_data(fid).contents.fe
                fix.append((e.sttime, e.entime, e.gavx, e.gavy, EYES.get(e.eye, e.eye)))
            elif t == ec["MESSAGEEVENT"]:
                e = api.edf_get_float_data(fid).contents.fe
                if e.message:
                    n = e.message.contents.len
                    txt = ct.string_at(ct.byref(e.message[0]), n + 2)[2:]
                    msgs.append(txt.decode("latin-1").rstrip("\x00"))
    finally:
        api.edf_close_file(fid)
    return fix, msgs


def read_asc(path):
    fix, msgs = [], []
    with open(path, encoding="latin-1") as f:
        for line in f:
            if line.startswith("EFIX"):
                p = line.split()
                if len(p) < 7:
                    die(f"{path}: short EFIX line: {line.strip()}")
                x = float("nan") if p[5] == "." else float(p[5])
                y = float("nan") if p[6] == "." else float(p[6])
                fix.append((int(p[2]), int(p[3]), x, y, p[1]))
            elif line.startswith("MSG") and "_COORDS" in line:
                msgs.append(line.split(None, 2)[2] if len(line.split()) > 2 else line)
    return fix, msgs


def coords(msgs, key):
    for m in msgs:
        g = re.search(key + r"\s+([-\d.]+)\s+([-\d.]+)\s+([-\d.]+)\s+([-\d.]+)", m)
        if g:
            return tuple(float(v) for v in g.groups())
    return None


def screen_size(c):
    x0, y0, x1, y1 = c
    w, h = x1 - x0, y1 - y0
    if w in COMMON_W and w % 2 == 0 and h % 2 == 0:
        return int(w), int(h)      # `0 0 1920 1080`: the size, not the last pixel
    return int(round(w + 1)), int(round(h + 1))


def fmt(c):
    return "none" if c is None else " ".join(f"{v:g}" for v in c)


def main(argv):
    if len(argv) >= 3 and argv[0] == "unzip":
        unzip(argv[1], argv[2], argv[3:])
        return
    opts = {"--eye": None, "--screen": None}
    args = []
    it = iter(argv)
    for a in it:
        if a in opts:
            opts[a] = next(it, None)
        else:
            args.append(a)
    if len(args) == 4 and args[0] == "edf":
        _, wheel_dir, src, out = args
        fix, msgs = read_edf(wheel_dir, src)
    elif len(args) == 3 and args[0] == "asc":
        _, src, out = args
        fix, msgs = read_asc(src)
    else:
        die(__doc__)
    eyes = sorted({f[4] for f in fix})
    eye = opts["--eye"]
    if eye is None:
        if len(eyes) != 1:
            die(f"{src}: fixations of eyes {eyes}; pick one with --eye")
        eye = eyes[0]
    kept = [f for f in fix if f[4] == eye]
    if not kept:
        die(f"{src}: no fixations of eye {eye} (eyes: {eyes})")
    good = [f for f in kept if abs(f[2]) < BAD and abs(f[3]) < BAD]  # nan fails too
    good.sort(key=lambda f: (f[0], f[1]))
    dc, gc = coords(msgs, "DISPLAY_COORDS"), coords(msgs, "GAZE_COORDS")
    c = dc or gc
    if c is None:
        die(f"{src}: no DISPLAY_COORDS or GAZE_COORDS message")
    w, h = screen_size(c)
    if opts["--screen"] and opts["--screen"] != f"{w}x{h}":
        die(f"{src}: screen {w}x{h} from `{fmt(c)}`, expected {opts['--screen']}")
    tmp = out + ".tmp"
    with open(tmp, "w", newline="") as fh:
        wr = csv.writer(fh, lineterminator="\n")
        wr.writerow(["start_ms", "end_ms", "x", "y"])
        for st, en, x, y, _ in good:
            wr.writerow([st, en, f"{x:.1f}", f"{y:.1f}"])
    os.replace(tmp, out)
    print(f"{os.path.basename(out)}: fixations={len(good)} dropped={len(kept) - len(good)} "
          f"eye={eye} screen={w}x{h} DISPLAY_COORDS={fmt(dc)} GAZE_COORDS={fmt(gc)}")


if __name__ == "__main__":
    main(sys.argv[1:])

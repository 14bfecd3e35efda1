#!/usr/bin/env python3
"""Stops eyereplay at random moments inside its most delicate steps, many
times, and counts what each stop left (docs/CHANGELOG.md, "Input checks",
stopped runs). Python 3 standard library only; runs from the repository
root with the tiny config's data fetched (scripts/setup.sh):

    python3 scripts/dev/stop_races.py [--bin target/release/eyereplay] [--tries 40] [--seed 11]

Two races, each its own table:

- report: `evaluate` of a finished tiny dataset, SIGINT to eyereplay's pid
  0-30 ms after its `.report.tmp*` folder appears (the window in which
  the new report is written and swapped in). Each stop must end one of
  two ways: stopped (status 130, one line `stopped...`, no summary) or,
  landing once the report was in place, finished (status 0, the summary);
  either way no hidden folder is left and the report's files are those of
  a clean run, byte for byte.
- staged: `generate` of the tiny config, SIGINT to the process group (a
  terminal's Ctrl-C) 0-40 ms after a session's `.staged.*` files appear.
  It must stop with status 130 and its one line, leave no hidden file,
  and `generate` run again must give a clean run's files byte for byte.

Exits 1 if any stop ended otherwise, printing each such stop.
"""
import argparse
import collections
import glob
import hashlib
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def hashes(folder, skip=("run.log",)):
    out = {}
    for root, _, files in os.walk(folder):
        for n in files:
            if n in skip:
                continue
            p = os.path.join(root, n)
            with open(p, "rb") as f:
                out[os.path.relpath(p, folder)] = hashlib.sha256(f.read()).hexdigest()
    return out


def hidden(folder):
    return sorted(
        os.path.relpath(os.path.join(r, n), folder)
        for r, ds, fs in os.walk(folder)
        for n in ds + fs
        if n.startswith(".")
    )


def start(argv, env):
    # Its own session, SIGINT at its default: a background shell would
    # have it ignored, and the child would inherit that.
    return subprocess.Popen(
        argv,
        cwd=ROOT,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )


def wait_for(p, pattern, limit_s=120):
    t0 = time.time()
    while p.poll() is None and not glob.glob(pattern):
        if time.time() - t0 > limit_s:
            p.kill()
            sys.exit(f"error: {pattern} never appeared")
        time.sleep(0.001)
    return p.poll() is None


def stop_once(argv, env, pattern, max_delay_s, rng, send):
    """Starts argv, waits for pattern, then up to max_delay_s more, and
    stops it with send(pid); returns (status, stderr), or None if it ended
    before pattern appeared."""
    p = start(argv, env)
    if not wait_for(p, pattern):
        p.communicate()
        return None
    time.sleep(rng.uniform(0, max_delay_s))
    send(p.pid)
    _, err = p.communicate()
    return p.returncode, err


def report_race(args, env, base, work, rng):
    d = os.path.join(work, "report_race")
    shutil.copytree(base, d)
    want = hashes(os.path.join(d, "report"))
    counts, bad = collections.Counter(), []
    for i in range(args.tries):
        stopped = stop_once([args.bin, "evaluate", d], env, os.path.join(d, ".report.tmp*"), 0.03,
                            rng, lambda pid: os.kill(pid, signal.SIGINT))
        if stopped is None:
            counts["ended before the window"] += 1
            continue
        status, err = stopped
        lines = err.strip().splitlines()
        left = hidden(d)
        whole = hashes(os.path.join(d, "report")) == want
        if status == 130 and len(lines) == 1 and lines[0].startswith("stopped"):
            outcome = "stopped (130, its one line)"
        elif status == 0 and lines and lines[-1].startswith("metrics: "):
            outcome = "finished (0, the summary): the stop came after the report was in place"
        else:
            outcome = "ANOMALY"
        if left or not whole:
            outcome = "ANOMALY"
        counts[outcome] += 1
        if outcome == "ANOMALY":
            bad.append(f"report try {i}: status {status}, left {left}, report whole {whole}, stderr {lines[-3:]}")
    return counts, bad


def staged_race(args, env, base, work, rng, cfg):
    o = os.path.join(work, "staged_race")
    want = hashes(base)
    counts, bad = collections.Counter(), []
    for i in range(args.tries):
        shutil.rmtree(o, ignore_errors=True)
        k = rng.randint(0, 3)
        stopped = stop_once([args.bin, "generate", "--config", cfg, "--out", o, "--no-evaluate"], env,
                            os.path.join(o, "*", f".staged.*_000{k}*"), 0.04, rng,
                            lambda pid: os.killpg(pid, signal.SIGINT))
        if stopped is None:
            counts["ended before the window"] += 1
            continue
        status, err = stopped
        lines = [l for l in err.strip().splitlines() if not l.startswith("warning:")]
        left = hidden(o)
        ok = status == 130 and len(lines) == 1 and lines[0].startswith("stopped") and not left
        r = subprocess.run([args.bin, "generate", "--config", cfg, "--out", o, "--no-evaluate"],
                           cwd=ROOT, env=env, capture_output=True, text=True)
        same = r.returncode == 0 and hashes(o) == want
        if ok and same:
            counts["stopped (130, its one line); resumed to a clean run's bytes"] += 1
        else:
            counts["ANOMALY"] += 1
            diff = sorted(set(hashes(o).items()) ^ set(want.items()))[:4]
            bad.append(f"staged try {i}: status {status}, left {left}, stderr {lines[-3:]}, resume {r.returncode}, differs {diff}")
    return counts, bad


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--bin", default=os.path.join(ROOT, "target/release/eyereplay"))
    ap.add_argument("--tries", type=int, default=40, help="stops per race (default 40)")
    ap.add_argument("--seed", type=int, default=11, help="seed of the random delays")
    ap.add_argument("--only", choices=["report", "staged"])
    args = ap.parse_args()
    args.bin = os.path.abspath(args.bin)
    if not os.access(args.bin, os.X_OK):
        sys.exit(f"error: {args.bin}: no eyereplay binary (cargo build --release -p eyereplay-cli)")
    env = dict(os.environ)
    env.setdefault("EYEREPLAY_CACHE", os.path.join(ROOT, ".cache"))
    cfg = os.path.join(ROOT, "examples/tiny.toml")
    rng = random.Random(args.seed)
    with tempfile.TemporaryDirectory() as work:
        base = os.path.join(work, "base")
        r = subprocess.run([args.bin, "generate", "--config", cfg, "--out", base],
                           cwd=ROOT, env=env, capture_output=True, text=True)
        if r.returncode != 0:
            sys.exit(f"error: the clean run failed: {r.stderr.strip()}")
        races = []
        if args.only in (None, "report"):
            races.append(("report: SIGINT 0-30 ms into `evaluate`'s report swap", report_race(args, env, base, work, rng)))
        if args.only in (None, "staged"):
            no_report = os.path.join(work, "base_no_report")
            subprocess.run([args.bin, "generate", "--config", cfg, "--out", no_report, "--no-evaluate"],
                           cwd=ROOT, env=env, capture_output=True, check=True)
            races.append(("staged: Ctrl-C 0-40 ms after a session's staged files appear",
                          staged_race(args, env, no_report, work, rng, cfg)))
    anomalies = []
    for title, (counts, bad) in races:
        print(f"{title} ({args.tries} tries, seed {args.seed})")
        for outcome, n in sorted(counts.items(), key=lambda kv: -kv[1]):
            print(f"  {n:4d}  {outcome}")
        anomalies += bad
    for a in anomalies:
        print(a)
    sys.exit(1 if anomalies else 0)


if __name__ == "__main__":
    main()

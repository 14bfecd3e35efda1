#!/usr/bin/env bash
# The cluster scale-out test (issue 7): sharded generation through a real,
# single-node Slurm cluster on loopback, against a single-machine run.
#
#   scripts/test-cluster.sh            run every check (about 30-60 s on 2 cores)
#   scripts/test-cluster.sh --strict   a check that cannot run is a failure (default when CI is set)
#   scripts/test-cluster.sh --setup    install what it needs (Slurm/munge from apt, PyYAML if the
#                                      system Python lacks it) and exit; idempotent
#
#  (a) docs/cluster/k8s-indexed-job.yaml parsed and checked (PyYAML; a minimal
#      parser when PyYAML is missing), the Slurm script's syntax, the docs'
#      engine facts;
#  (b) scripts/slurm-local.sh starts a cluster; a trivial job array and
#      docs/cluster/slurm-array.sbatch (unchanged, with a stub binary) show the
#      shard arguments each array task gets; then, when `eyereplay generate`
#      exists, `sbatch --array=0-3 --wait docs/cluster/slurm-array.sbatch`
#      renders the tiny config into one folder, `eyereplay merge` finishes it,
#      and every CSV/JSON must hash the same as a single-machine `generate`;
#  (c) one shard's sessions deleted: `merge` must refuse, naming them; the
#      documented rerun of that shard (EYEREPLAY_SHARDS) makes merge pass again.
#
# Environment: EYEREPLAY_BIN (default: the newer of target/release|debug/eyereplay),
# EYEREPLAY_TINY_CONFIG (default examples/tiny.toml), KEEP=1 keeps the work folder.
# Ends with the line 'N passed, M failed, K skipped'; exits non-zero on a failure.
set -uo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root" || exit 1

strict=0
[[ -n ${CI:-} && ${CI} != 0 && ${CI} != false ]] && strict=1
mode="test"
for a in "$@"; do
  case "$a" in
    --strict) strict=1 ;;
    --setup) mode=setup ;;
    -h|--help) sed -n '2,26p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "test-cluster: unknown argument $a" >&2; exit 2 ;;
  esac
done

# shellcheck source=scripts/slurm-local.sh
source "$root/scripts/slurm-local.sh"
venv="$root/.cache/venv-cluster"
pyyaml_pin="PyYAML==6.0.3"

python_with_yaml() {
  if python3 -c 'import yaml' 2>/dev/null; then echo python3
  elif [[ -x $venv/bin/python ]] && "$venv/bin/python" -c 'import yaml' 2>/dev/null; then echo "$venv/bin/python"
  else echo ""; fi
}

if [[ $mode == setup ]]; then
  slurm_local_install || exit 1
  if [[ -z $(python_with_yaml) ]]; then
    echo "test-cluster: PyYAML into $venv ($pyyaml_pin)"
    python3 -m venv "$venv" && "$venv/bin/pip" install -q "$pyyaml_pin" || exit 1
  fi
  echo "test-cluster: setup done"
  exit 0
fi

passed=0 failed=0 skipped=0
pass() { passed=$((passed + 1)); echo "ok   $1"; }
fail() { failed=$((failed + 1)); echo "FAIL $1${2:+: $2}"; }
skip() {
  if ((strict)); then fail "$1" "cannot run: $2"
  else skipped=$((skipped + 1)); echo "skip $1: $2"; fi
}
t0=$SECONDS
now() { date +%s.%N; }
since() { awk -v a="$1" -v b="$(now)" 'BEGIN { printf "%.1f", b - a }'; }

work="$(mktemp -d "${TMPDIR:-/tmp}/eyereplay-cluster.XXXXXX")"
single_pid=""
cleanup() {
  slurm_local_stop >/dev/null 2>&1 || true
  # the background single-machine run, if the test stops early
  if [[ -n $single_pid ]] && kill -0 "$single_pid" 2>/dev/null; then
    kill "$(cat "$work/single.pid" 2>/dev/null)" "$single_pid" 2>/dev/null
    wait "$single_pid" 2>/dev/null
  fi
  if [[ ${KEEP:-0} == 1 ]]; then echo "work folder kept: $work"; else rm -rf "$work"; fi
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

# ---------------------------------------------------------------- (a) docs
manifest="$root/docs/cluster/k8s-indexed-job.yaml"
py="$(python_with_yaml)"
if [[ -z $py ]]; then
  echo "note: PyYAML not found (scripts/test-cluster.sh --setup installs it): minimal YAML parser"
  py=python3
fi
while IFS= read -r line; do
  case "$line" in
    "ok "*) pass "k8s: ${line#ok }" ;;
    "not ok "*) fail "k8s: ${line#not ok }" ;;
    *) echo "$line" ;;
  esac
done < <("$py" - "$manifest" 2>&1 <<'PYEOF' || echo "not ok manifest check crashed"
import sys

def strip_comment(s):
    out, q = [], None
    for i, c in enumerate(s):
        if q:
            if c == q:
                q = None
        elif c in "\"'":
            q = c
        elif c == "#" and (i == 0 or s[i - 1] in " \t"):
            break
        out.append(c)
    return "".join(out).rstrip()

def scalar(v):
    v = v.strip()
    if v.startswith("[") and v.endswith("]"):
        inner = v[1:-1].strip()
        return [scalar(x) for x in inner.split(",")] if inner else []
    if len(v) >= 2 and v[0] == v[-1] and v[0] in "\"'":
        return v[1:-1]
    if v in ("true", "false"):
        return v == "true"
    if v in ("null", "~", ""):
        return None
    try:
        return int(v)
    except ValueError:
        return v

def split_key(s):
    if s[:1] in "\"'[{":
        return None
    i = s.find(": ")
    if i > 0:
        return s[:i].strip(), s[i + 2:]
    if s.endswith(":"):
        return s[:-1].strip(), ""
    return None

def parse_block(lines, i, indent):
    """The minimal YAML this manifest uses: block mappings and sequences,
    flow lists of scalars, quoted and plain scalars."""
    is_seq = lines[i][1] == "-" or lines[i][1].startswith("- ")
    if is_seq:
        seq = []
        while i < len(lines) and lines[i][0] == indent and (lines[i][1] == "-" or lines[i][1].startswith("- ")):
            item = lines[i][1][2:].strip()
            if not item:
                v, i = parse_block(lines, i + 1, lines[i + 1][0])
            elif split_key(item):
                lines[i] = (indent + 2, item)
                v, i = parse_block(lines, i, indent + 2)
            else:
                v, i = scalar(item), i + 1
            seq.append(v)
        return seq, i
    m = {}
    while i < len(lines) and lines[i][0] == indent and not lines[i][1].startswith("- "):
        kv = split_key(lines[i][1])
        if kv is None:
            raise ValueError("line %r: expected 'key: value'" % lines[i][1])
        k, v = kv
        i += 1
        if v.strip():
            m[k] = scalar(v)
        elif i < len(lines) and (lines[i][0] > indent or (lines[i][0] == indent and lines[i][1].startswith("- "))):
            m[k], i = parse_block(lines, i, lines[i][0])
        else:
            m[k] = None
    return m, i

def mini_load_all(text):
    docs, cur = [], []
    for raw in text.splitlines() + ["---"]:
        if raw.strip() == "---":
            if cur:
                v, i = parse_block(cur, 0, cur[0][0])
                if i != len(cur):
                    raise ValueError("unparsed line %r" % (cur[i][1],))
                docs.append(v)
            cur = []
            continue
        s = strip_comment(raw)
        if s.strip():
            cur.append((len(s) - len(s.lstrip(" ")), s.strip()))
    return docs

path = sys.argv[1]
text = open(path).read()
try:
    import yaml
    docs = [d for d in yaml.safe_load_all(text) if d is not None]
    print("(parsed with PyYAML %s)" % yaml.__version__)
    mini = mini_load_all(text)
    print(("ok" if mini == docs else "not ok") + " minimal fallback parser agrees with PyYAML")
except ImportError:
    docs = mini_load_all(text)
    print("(parsed with the minimal parser)")

def check(name, cond, why=""):
    print(("ok " if cond else "not ok ") + name + ("" if cond else (": " + why if why else "")))
    return cond

jobs = [d for d in docs if isinstance(d, dict) and d.get("kind") == "Job"]
if not check("one kind: Job (batch/v1)", len(jobs) == 1 and jobs[0].get("apiVersion") == "batch/v1",
             "found %d Job documents" % len(jobs)):
    sys.exit(0)
job = jobs[0]
spec = job.get("spec") or {}
check("completionMode: Indexed", spec.get("completionMode") == "Indexed", repr(spec.get("completionMode")))
n, par = spec.get("completions"), spec.get("parallelism")
check("completions == parallelism", isinstance(n, int) and n >= 1 and n == par, "completions %r, parallelism %r" % (n, par))
pod = (spec.get("template") or {}).get("spec") or {}
check("restartPolicy Never or OnFailure", pod.get("restartPolicy") in ("Never", "OnFailure"), repr(pod.get("restartPolicy")))
containers = pod.get("containers") or []
gen = None
for c in containers:
    argv = [str(x) for x in (c.get("command") or []) + (c.get("args") or [])]
    # 'eyereplay generate', directly or inside 'sh -c "..."'
    words = " ".join(argv).split()
    for j in range(len(words) - 1):
        if words[j].split("/")[-1] == "eyereplay" and words[j + 1] == "generate":
            gen = (c, argv, words)
if not check("a container runs 'eyereplay generate'", gen is not None, "no command/args with 'eyereplay generate'"):
    sys.exit(0)
c, argv, words = gen
env = {e.get("name"): e for e in (c.get("env") or [])}
def flag(name):
    for j, w in enumerate(words):
        if w == name and j + 1 < len(words):
            return words[j + 1]
        if w.startswith(name + "="):
            return w.split("=", 1)[1]
    return None
out, config = flag("--out"), flag("--config")
check("--config and --out given", bool(out) and bool(config), "argv %r" % argv)
shard, shards = flag("--shard"), flag("--shards")
env_shards = (env.get("EYEREPLAY_SHARDS") or {}).get("value")
count = shards if shards and not shards.startswith("$(") else env_shards
check("the shard count (--shards / EYEREPLAY_SHARDS) equals completions", count is not None and str(count) == str(n),
      "count %r, completions %r" % (count, n))
if shard is not None:
    check("--shard is built from JOB_COMPLETION_INDEX", "JOB_COMPLETION_INDEX" in shard, repr(shard))
    if "$(JOB_COMPLETION_INDEX)" in shard:
        ref = ((env.get("JOB_COMPLETION_INDEX") or {}).get("valueFrom") or {}).get("fieldRef") or {}
        check("JOB_COMPLETION_INDEX declared for $(...) expansion",
              "job-completion-index" in str(ref.get("fieldPath", "")), repr(ref))
vols = {v.get("name"): v for v in (pod.get("volumes") or [])}
mounts = c.get("volumeMounts") or []
shared = None
for mnt in mounts:
    mp = str(mnt.get("mountPath", "")).rstrip("/")
    if out and (out == mp or out.startswith(mp + "/")):
        shared = vols.get(mnt.get("name"))
ok = shared is not None and "persistentVolumeClaim" in shared
check("--out lies on a mounted PersistentVolumeClaim (shared output)", ok, "out %r, mounts %r" % (out, mounts))
if ok:
    claim = shared["persistentVolumeClaim"].get("claimName")
    pvcs = [d for d in docs if isinstance(d, dict) and d.get("kind") == "PersistentVolumeClaim"
            and (d.get("metadata") or {}).get("name") == claim]
    if pvcs:
        modes = (pvcs[0].get("spec") or {}).get("accessModes") or []
        check("the claim is ReadWriteMany (pods on many nodes)", "ReadWriteMany" in modes, repr(modes))
PYEOF
)

if bash -n docs/cluster/slurm-array.sbatch 2>"$work/bashn.err"; then pass "slurm-array.sbatch: bash syntax"
else fail "slurm-array.sbatch: bash syntax" "$(head -3 "$work/bashn.err")"; fi
if grep -q '^#SBATCH --job-name' docs/cluster/slurm-array.sbatch && ! grep -q '^#SBATCH --array' docs/cluster/slurm-array.sbatch; then
  pass "slurm-array.sbatch: #SBATCH header (array size left to the command line)"
else fail "slurm-array.sbatch: #SBATCH header" "expected --job-name and no fixed --array"; fi
readme=docs/cluster/README.md
missing_facts=()
# shellcheck disable=SC2016  # literal text to find
for fact in SLURM_ARRAY_TASK_ID SLURM_ARRAY_TASK_COUNT JOB_COMPLETION_INDEX '{#}' '$(Process)' 'eyereplay merge' '144' '7,500' 'temp file'; do
  grep -qF -- "$fact" "$readme" 2>/dev/null || missing_facts+=("$fact")
done
if ((${#missing_facts[@]} == 0)); then pass "docs/cluster/README.md: engines' shard indices, shared storage, merge, paper scale"
else fail "docs/cluster/README.md" "does not mention: ${missing_facts[*]}"; fi

# ---------------------------------------------------------------- (b) cluster
if [[ $(id -u) -ne 0 ]]; then
  skip "slurm cluster" "needs root"
  echo "cluster test: $((SECONDS - t0)) s"
  echo "${passed} passed, ${failed} failed, ${skipped} skipped"
  ((failed == 0)); exit $?
fi

bin="${EYEREPLAY_BIN:-}"
if [[ -z $bin ]]; then
  for b in target/release/eyereplay target/debug/eyereplay; do
    [[ -x $b ]] || continue
    if [[ -z $bin || $b -nt $bin ]]; then bin="$b"; fi
  done
fi
[[ -n $bin && $bin != /* && -x $bin ]] && bin="$root/$bin"
cfg="${EYEREPLAY_TINY_CONFIG:-examples/tiny.toml}"
[[ -f $cfg ]] && cfg="$(cd "$(dirname "$cfg")" && pwd)/$(basename "$cfg")"
why=""
if [[ -z $bin || ! -x $bin ]]; then why="no eyereplay binary (build it, or set EYEREPLAY_BIN)"
elif ! "$bin" generate --help >/dev/null 2>&1; then why="$bin has no 'generate' yet"
elif ! "$bin" merge --help >/dev/null 2>&1; then why="$bin has no 'merge' yet"
elif [[ ! -f $cfg ]]; then why="config $cfg not found (EYEREPLAY_TINY_CONFIG)"
fi

# The single-machine reference run goes on in the background meanwhile (it
# renders on one core; the cluster's tasks take the other).
out_c="$work/out-cluster" out_s="$work/out-single"
mkdir -p "$work/logs"
if [[ -z $why ]]; then
  ts_single="$(now)"
  (
    "$bin" generate --config "$cfg" --out "$out_s" >"$work/logs/single.log" 2>&1 &
    echo $! >"$work/single.pid"
    src=0; wait $! || src=$?
    echo "$src" >"$work/single.rc"
    since "$ts_single" >"$work/single.time"
  ) &
  single_pid=$!
fi

ts="$(now)"
if slurm_local_start "$work/slurm" 2>"$work/slurm-start.log"; then
  pass "slurm-local: cluster up, node idle ($(since "$ts") s)"
else
  cat "$work/slurm-start.log"
  fail "slurm-local: cluster start"
  echo "${passed} passed, ${failed} failed, ${skipped} skipped"
  exit 1
fi

# The docs' script, unchanged, with a stub binary that records what each
# array task got: a 4-task array (--array=1-4: shards 0/4..3/4), and the
# documented rerun of one shard (EYEREPLAY_SHARDS), submitted together.
mkdir -p "$work/stub"
cat >"$work/stub/eyereplay" <<EOF
#!/usr/bin/env bash
echo "\$SLURM_ARRAY_TASK_ID \$SLURM_ARRAY_TASK_COUNT" >"$work/stub/env.\$SLURM_ARRAY_TASK_ID"
printf '%s\n' "\$*" >"$work/stub/args.\$SLURM_ARRAY_TASK_ID"
EOF
chmod +x "$work/stub/eyereplay"
ts="$(now)"
EYEREPLAY_BIN="$work/stub/eyereplay" sbatch --wait --quiet --array=1-4 --output="$work/logs/stub-%a.out" \
  docs/cluster/slurm-array.sbatch /cfg/tiny.toml /shared/out --no-evaluate &
p2=$!
EYEREPLAY_BIN="$work/stub/eyereplay" EYEREPLAY_SHARDS=8 sbatch --wait --quiet --array=5 --output="$work/logs/stub-%a.out" \
  docs/cluster/slurm-array.sbatch /cfg/tiny.toml /shared/out &
p3=$!
rc2=0 rc3=0
wait $p2 || rc2=$?
wait $p3 || rc3=$?
t_stub="$(since "$ts")"
got="$(cat "$work"/stub/env.[1-4] 2>/dev/null | tr '\n' ' ')"
if [[ $rc2 == 0 && $got == "1 4 2 4 3 4 4 4 " ]]; then
  pass "slurm: sbatch --array=1-4 --wait ran 4 tasks, each with its SLURM_ARRAY_TASK_ID/COUNT (${t_stub} s)"
else fail "slurm: job array" "sbatch rc $rc2, tasks saw '$got'"; fi
want="generate --config /cfg/tiny.toml --out /shared/out --shard 0/4 --no-evaluate|generate --config /cfg/tiny.toml --out /shared/out --shard 1/4 --no-evaluate|generate --config /cfg/tiny.toml --out /shared/out --shard 2/4 --no-evaluate|generate --config /cfg/tiny.toml --out /shared/out --shard 3/4 --no-evaluate"
got="$(cat "$work"/stub/args.1 "$work"/stub/args.2 "$work"/stub/args.3 "$work"/stub/args.4 2>/dev/null | paste -sd'|')"
if [[ $rc2 == 0 && $got == "$want" ]]; then pass "slurm-array.sbatch: --array=1-4 runs shards 0/4..3/4 (args passed on)"
else fail "slurm-array.sbatch: shard arguments" "sbatch rc $rc2, got '$got'"; cat "$work"/logs/stub-*.out 2>/dev/null; fi
got="$(cat "$work/stub/args.5" 2>/dev/null)"
if [[ $rc3 == 0 && $got == "generate --config /cfg/tiny.toml --out /shared/out --shard 5/8" ]]; then
  pass "slurm-array.sbatch: rerun of one shard with EYEREPLAY_SHARDS (--array=5 -> 5/8)"
else fail "slurm-array.sbatch: EYEREPLAY_SHARDS rerun" "sbatch rc $rc3, got '$got'"; fi

# ---------------------------------------------------------------- real generate/merge
hashes() { (cd "$1" && find . -type f \( -name '*.csv' -o -name '*.json' \) ! -name run.log -print0 | sort -z | xargs -0 -r sha256sum); }

if [[ -n $why ]]; then
  skip "slurm: sharded generate + merge == single machine" "$why"
  skip "merge refuses when a shard's sessions are missing" "$why"
else
  export EYEREPLAY_BIN="$bin"
  echo "real run: $bin, config $cfg"
  ts="$(now)"
  rc=0
  sbatch --wait --quiet --array=0-3 --output="$work/logs/gen-%a.out" \
    docs/cluster/slurm-array.sbatch "$cfg" "$out_c" >"$work/logs/sbatch-gen.log" 2>&1 || rc=$?
  t_array="$(since "$ts")"
  ts="$(now)"
  mrc=0
  [[ $rc == 0 ]] && { "$bin" merge "$out_c" >"$work/logs/merge.log" 2>&1 || mrc=$?; }
  t_merge="$(since "$ts")"
  wait "$single_pid"
  src="$(cat "$work/single.rc" 2>/dev/null || echo 99)"
  t_single="$(cat "$work/single.time" 2>/dev/null)"
  if [[ $rc != 0 ]]; then
    fail "slurm: sbatch --array=0-3 --wait docs/cluster/slurm-array.sbatch" "exit $rc"
    tail -n 20 "$work"/logs/sbatch-gen.log "$work"/logs/gen-*.out
  elif [[ $mrc != 0 ]]; then
    fail "eyereplay merge after the array" "exit $mrc: $(tail -n 3 "$work/logs/merge.log")"
  elif [[ $src != 0 ]]; then
    fail "single-machine generate" "exit $src: $(tail -n 5 "$work/logs/single.log")"
  else
    hashes "$out_c" >"$work/h-cluster.txt"; hashes "$out_s" >"$work/h-single.txt"
    nfiles=$(wc -l <"$work/h-single.txt")
    if [[ -f $out_c/labels.csv && -f $out_c/metadata.json && $nfiles -gt 2 ]] && cmp -s "$work/h-cluster.txt" "$work/h-single.txt"; then
      pass "slurm: 4 shards + merge == single machine ($nfiles CSV/JSON files identical; array ${t_array} s, merge ${t_merge} s, single ${t_single} s)"
    else
      fail "slurm: 4 shards + merge == single machine" "$nfiles files; differences:"
      diff "$work/h-single.txt" "$work/h-cluster.txt" | head -n 20
      # The first differing lines of each differing file.
      join -j 2 <(sort -k2 "$work/h-single.txt") <(sort -k2 "$work/h-cluster.txt") |
        awk '$2 != $3 {print $1}' | head -n 5 | while read -r f; do
          echo "  $f (single vs cluster):"
          diff <(fold -w 200 "$out_s/$f") <(fold -w 200 "$out_c/$f") | head -n 6 | cut -c1-240 | sed 's/^/    /'
        done
    fi
  fi

  # (c) delete shard 2's rendered sessions (sessions are dealt round-robin in
  # labels.csv order: session i belongs to shard i mod 4), merge must refuse.
  if [[ $rc == 0 && $mrc == 0 ]]; then
    python3 - "$out_c" 2 4 >"$work/removed.txt" <<'PYEOF'
import csv, os, sys
d, k, n = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
rows = list(csv.DictReader(open(os.path.join(d, "labels.csv"), newline="")))
for i, r in enumerate(rows):
    if i % n != k:
        continue
    f = r["file"]
    folder, name = os.path.split(os.path.join(d, f))
    stem = os.path.splitext(name)[0]
    for e in sorted(os.listdir(folder)):
        # the session's rendered files: STEM.mp4, STEM_truth.csv, STEM_identity.json, ...
        if e != name and (e.startswith(stem + ".") or e.startswith(stem + "_")):
            os.remove(os.path.join(folder, e))
    print(f)
PYEOF
    nmiss=$(wc -l <"$work/removed.txt")
    mrc=0
    "$bin" merge --no-evaluate "$out_c" >"$work/logs/merge-missing.log" 2>&1 || mrc=$?
    msg="$(cat "$work/logs/merge-missing.log")"
    unnamed=()
    # Each named by its session (merge names the file at fault, its video).
    while IFS= read -r f; do [[ $msg == *"${f%.csv}."* ]] || unnamed+=("$f"); done < <(head -n 12 "$work/removed.txt")
    if ((nmiss == 0)); then
      fail "merge refuses when a shard's sessions are missing" "shard 2 of 4 has no sessions in labels.csv (config too small)"
    elif [[ $mrc != 0 && ${#unnamed[@]} == 0 ]]; then
      pass "merge refuses a dataset missing shard 2's $nmiss session(s), naming them: $(grep -m1 -i 'not rendered\|missing' <<<"$msg" | cut -c1-160)"
    else
      fail "merge refuses when a shard's sessions are missing" "exit $mrc, not named: ${unnamed[*]:-}; output: $(tail -n 3 <<<"$msg")"
    fi
    # The documented recovery: rerun only that shard, merge passes again.
    ts="$(now)"
    rrc=0
    EYEREPLAY_SHARDS=4 sbatch --wait --quiet --array=2 --output="$work/logs/rerun-%a.out" \
      docs/cluster/slurm-array.sbatch "$cfg" "$out_c" >"$work/logs/sbatch-rerun.log" 2>&1 || rrc=$?
    mrc=0
    # (no second evaluation: the report of the first merge stays and is compared too)
    [[ $rrc == 0 ]] && { "$bin" merge --no-evaluate "$out_c" >"$work/logs/merge2.log" 2>&1 || mrc=$?; }
    if [[ $rrc == 0 && $mrc == 0 ]] && cmp -s <(hashes "$out_c") "$work/h-single.txt"; then
      pass "rerun of shard 2 alone (--array=2, EYEREPLAY_SHARDS=4) + merge == single machine again ($(since "$ts") s)"
    else
      fail "rerun of shard 2 + merge" "sbatch exit $rrc, merge exit $mrc"
      tail -n 10 "$work"/logs/rerun-*.out "$work/logs/merge2.log" 2>/dev/null
    fi
  fi
fi

ts="$(now)"
if slurm_local_stop 2>"$work/slurm-stop.log"; then
  left="$(for n in slurmctld slurmd slurmstepd munged; do pgrep -a -x "$n"; done | grep -F "$work/" || true)"
  if [[ -z $left ]]; then pass "slurm-local: cluster shut down, nothing left running ($(since "$ts") s)"
  else fail "slurm-local: shutdown" "still running: $left"; fi
else
  cat "$work/slurm-stop.log"
  fail "slurm-local: shutdown"
fi
echo "cluster test: $((SECONDS - t0)) s"
echo "${passed} passed, ${failed} failed, ${skipped} skipped"
((failed == 0))

#!/usr/bin/env bash
# compute-sanitizer's four tools over every CUDA test and every shipped scene, spread over this host's GPUs, in
# one call of a stated length.
#   scripts/sanitize_gpu.sh BUILD_DIR [TOOL...]      (default tools: memcheck racecheck initcheck synccheck)
#     BUILD_DIR  a build of the `cuda` preset (built here first when it has no build.ninja)
#   SANITIZE_BUDGET_S   wall seconds of the whole sweep (default 330); a run not begun by then is "not run", a run
#                       still going then is cut ("cut": not covered, never counted as clean)
#   SANITIZE_RUN_S      the most seconds of one run (default 240)
#   SANITIZE_JOBS       runs at once (default 8 per GPU, at most the cores / 2)
#   SANITIZE_RESUME=1   keep $OUT/sanitize/runs.jsonl and run only what it does not list as clean (a second call
#                       for what the first one's budget left; the summary then covers both)
#   SANITIZE_LAUNCHES   memcheck, racecheck and synccheck check the first N kernel launches of each run (default
#                       400; 0: all): a test launches all its kernels within its first steps, and its later
#                       steps run uninstrumented. initcheck checks every launch: with a limit, the writes of the
#                       uninstrumented launches are not recorded and its host-copy check then reports bytes
#                       they did write (the false reports of the last sweep)
#   SANITIZE_WHILE      a regular expression on run names whose pressure solve loops in a CUDA graph with a
#                       conditional (WHILE) node (default: the gas-solid bed scenes and the CFD tests). No tool
#                       checks kernels inside conditional nodes soundly (scripts/sanitizer_while_probe.cu, a correct
#                       program): synccheck and racecheck report barrier errors and fail runs there and are clean
#                       with the same kernels launched one by one; memcheck's instrumented kernels outgrow the stack
#                       a conditional body's kernels are given (a kernel with a local array in the body ends in an
#                       unattributed cudaErrorIllegalAddress under memcheck every time, and runs clean with the
#                       device's stack limit raised to 16 KB, or launched one by one). Every tool therefore runs
#                       every run with LBDEM_PRESSURE_DEVICE_LOOP=0 (the same kernels, the loop polled from the host;
#                       nothing else reads it); memcheck checks every launch of the runs this expression names.
#                       LBDEM_CUDA_STACK_BYTES=16384 (core/src/exec.cpp: the device's stack limit, set when lbdem or a
#                       test first finds the GPU) with LBDEM_PRESSURE_DEVICE_LOOP=1 lets memcheck check the loop itself
#   SANITIZE_CHILDREN   a regular expression on test names that start `lbdem` processes on the GPU (default: the
#                       GPU restart test and the GPU-rank cuts of cases_tests): the tool follows them
#                       (--target-processes all). Left to run outside the tool, those processes did not get through
#                       (every tool's run cut at its time limit with no output after the test's start)
#   SANITIZE_NOAPI      a regular expression on run names for which memcheck does not report CUDA API errors
#                       (default: the halo tests that start NCCL, whose set-up probes kernels with
#                       cudaFuncGetAttributes, gets cudaErrorNoKernelImageForDevice and handles it; lbdem's own
#                       CUDA calls are all checked, so an API error of ours still fails the test)
#   SANITIZE_GPUS       the GPUs to use, e.g. "1 2 3" (default: all; another job can then time itself on the rest)
#   SANITIZE_FILTER     an extra regular expression on the test names (default: all)
#   SCENE_STEPS         steps of each scene (default 5)
#   SANITIZER           compute-sanitizer (default: the one beside nvcc, else on PATH)
# What runs: every test of `ctest -L gpu` (each discovered test alone, as CTest runs it: the executable with its
# --gtest_filter; the mpiexec tests with the sanitizer in front of every rank), and `lbdem run --backend cuda
# --steps SCENE_STEPS` of every cases/*.yaml (the paper-size variants in cases/suspension/ run the `suspension`
# scene's code at sizes a sanitizer cannot take in minutes; not included). Each run gets one GPU
# (CUDA_VISIBLE_DEVICES, round robin), longest-expected first (scenes and the long-labelled tests).
# Writes under $OUT/sanitize/: runs.jsonl (one line per run: tool, target, name, status clean|errors|test_failed|
# cut|not_run, the sanitizer's summary line, exit code, seconds), <tool>/<target>/<name>.log (the first 60 lines from the first report and the last 25 of
# each run that was not clean), summary.txt; $OUT/sanitize.jsonl one line per tool x target (runs, clean, errors,
# test failures, cut, not run, and the names of all but the clean).
# Prints one line per tool x target. Exit status: 0 when every run was clean (a scene's own exit code does not
# count: fixed_disk and fixed_sphere exit 1 by design after 5 steps; a test that fails under a sanitizer does).
set -uo pipefail
source "$(dirname "$0")/lib.sh"
lbdem_env
build="${1:?usage: scripts/sanitize_gpu.sh BUILD_DIR [TOOL...]}"
shift
tools=("$@")
[ ${#tools[@]} -gt 0 ] || tools=(memcheck racecheck initcheck synccheck)
build="$(realpath -m "$build")"
[ -f "$build/build.ninja" ] || lbdem_build "$build" || exit 1
cs="${SANITIZER:-}"
if [ -z "$cs" ]; then
  for c in /usr/local/cuda/bin/compute-sanitizer "$(dirname "$(command -v nvcc 2>/dev/null || echo /x/x)")/compute-sanitizer" \
    "$(command -v compute-sanitizer 2>/dev/null)"; do
    [ -n "$c" ] && [ -x "$c" ] && { cs="$c"; break; }
  done
fi
[ -n "$cs" ] && [ -x "$cs" ] || { echo "sanitize_gpu: compute-sanitizer not found (set SANITIZER)"; exit 2; }
ngpu=$(gpu_count)
[ "$ngpu" -gt 0 ] || { echo "sanitize_gpu: no GPU (nvidia-smi -L lists none)"; exit 1; }
gpus="${SANITIZE_GPUS:-$(seq -s ' ' 0 $((ngpu - 1)))}"
ngpu=$(echo $gpus | wc -w)
cores=$(nproc)
jobs="${SANITIZE_JOBS:-$((8 * ngpu < cores / 2 ? 8 * ngpu : cores / 2))}"
[ "$jobs" -ge 1 ] || jobs=1
dir="$OUT/sanitize"
mkdir -p "$dir"
export OMP_NUM_THREADS=1 OMP_WAIT_POLICY=passive
echo "sanitize_gpu: $ngpu GPUs, $jobs runs at once, tools ${tools[*]}, budget ${SANITIZE_BUDGET_S:-330} s, $("$cs" --version | tail -1)"

ctest --test-dir "$build" -L gpu --show-only=json-v1 > "$dir/ctest.json" 2> "$dir/ctest.err" ||
  { echo "sanitize_gpu: ctest could not list the tests"; tail -5 "$dir/ctest.err"; exit 1; }

python3 - "$dir" "$cs" "$build" "$LBDEM_ROOT" "$gpus" "$jobs" "${tools[@]}" <<'PY'
import json, os, re, subprocess, sys, tempfile, threading, time, glob, shutil
out, cs, build, root, gpus, jobs = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4], sys.argv[5].split(), int(sys.argv[6])
ngpu = len(gpus)
tools = sys.argv[7:]
budget = float(os.environ.get("SANITIZE_BUDGET_S", "330"))
run_cap = float(os.environ.get("SANITIZE_RUN_S", "240"))
launches = int(os.environ.get("SANITIZE_LAUNCHES", "400"))
cond_graph = re.compile(os.environ.get("SANITIZE_WHILE", r"^fluidized_bed|FluidizedBed|^All/(Gas|Pressure|Settling|VoidFraction)"))
noapi = re.compile(os.environ.get("SANITIZE_NOAPI", r"^halo_mpi_tests"))
children = re.compile(os.environ.get("SANITIZE_CHILDREN", r"^Restart\..*Cuda|MpiParticles\..*/gpu"))
commit = os.environ.get("LBDEM_COMMIT", "")
flt = re.compile(os.environ.get("SANITIZE_FILTER", ""))
steps = os.environ.get("SCENE_STEPS", "5")
t0 = time.time()

# The targets: CTest's GPU tests (command, labels), then the scenes.
runs = []
for t in json.load(open(os.path.join(out, "ctest.json")))["tests"]:
    name, cmd = t["name"], t.get("command") or []
    if not cmd or not flt.search(name):
        continue
    labels = []
    for p in t.get("properties", []):
        if p["name"] == "LABELS":
            labels = p["value"]
    # The test executable: the first argument under the build's tests/ folder (after mpiexec and its flags).
    exe_at = next((i for i, a in enumerate(cmd) if a.startswith(os.path.join(build, "tests"))), None)
    if exe_at is None:
        continue
    target = os.path.basename(cmd[exe_at]) + (("." + name.rsplit(".", 1)[1]) if exe_at > 0 else "")
    runs.append(dict(kind="test", name=name, target=target, cmd=cmd, exe_at=exe_at, long="long" in labels,
                     cwd=t.get("properties") and next((p["value"] for p in t["properties"]
                                                        if p["name"] == "WORKING_DIRECTORY"), None)))
scenes = sorted(glob.glob(os.path.join(root, "cases", "*.yaml")))
for s in scenes:
    n = os.path.splitext(os.path.basename(s))[0]
    if flt.search(n):
        runs.append(dict(kind="scene", name=n, target="scenes", yaml=s, long=True))

# A resumed sweep: the runs an earlier call found clean count as they are.
earlier = []
runs_file = os.path.join(out, "runs.jsonl")
if os.environ.get("SANITIZE_RESUME") == "1" and os.path.exists(runs_file):
    for line in open(runs_file):
        r = json.loads(line)
        if r["status"] == "clean" and r["name"] in {w["name"] for w in runs}:  # still a target of this build
            earlier.append(r)
done_before = {(r["tool"], r["name"]) for r in earlier}
work = []
for tool in tools:
    for r in runs:
        if (tool, r["name"]) not in done_before:
            work.append(dict(r, tool=tool))
# Longest expected first (scenes and long tests), then the rest; tools interleaved so each progresses.
work.sort(key=lambda w: (not w["long"], w["kind"] != "scene"))
lock = threading.Lock()
results = list(earlier)
slots = [0] * ngpu
nxt = [0]

def one(w, gpu):
    left = t0 + budget - time.time()
    rec = dict(tool=w["tool"], target=w["target"], name=w["name"], gpu=gpu, commit=commit)
    if left < 10:
        rec.update(status="not_run", summary="", exit=None, seconds=0)
        return rec
    opts = [cs, "--tool", w["tool"], "--error-exitcode", "99", "--print-limit", "20"]
    if w["tool"] == "memcheck":
        opts += ["--leak-check", "full"]
    if w["tool"] == "racecheck":
        opts += ["--racecheck-report", "hazard"]
    while_node = bool(cond_graph.search(w["name"]))
    if launches > 0 and w["tool"] != "initcheck" and not (while_node and w["tool"] == "memcheck"):
        opts += ["--launch-count", str(launches)]
    if w["tool"] == "memcheck" and noapi.search(w["name"]):
        opts += ["--report-api-errors", "no"]
    if children.search(w["name"]):
        opts += ["--target-processes", "all"]
        rec["target_processes"] = "all"
    tmp = tempfile.mkdtemp(prefix="lbdem_san_")
    env = dict(os.environ, CUDA_VISIBLE_DEVICES=str(gpu), TMPDIR=tmp)
    env["LBDEM_PRESSURE_DEVICE_LOOP"] = "0"  # every run: only the pressure solve reads it
    if while_node:
        rec["pressure_loop"] = "polled"
    env.pop("CTEST_RESOURCE_GROUP_COUNT", None)
    if w["kind"] == "scene":
        cmd = opts + [os.path.join(build, "cases", "lbdem"), "run", w["yaml"], "--backend", "cuda", "--steps", steps,
                      "--output", os.path.join(tmp, "run"), "--quiet"]
        cwd = tmp
    else:
        c = w["cmd"]
        cmd = c[:w["exe_at"]] + opts + c[w["exe_at"]:]
        cwd = w["cwd"] or tmp
    ts = time.time()
    try:
        p = subprocess.run(cmd, cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                           timeout=max(5.0, min(run_cap, left)))
        text, code = p.stdout.decode(errors="replace"), p.returncode
    except subprocess.TimeoutExpired as e:
        text, code = (e.stdout or b"").decode(errors="replace"), 124
    shutil.rmtree(tmp, ignore_errors=True)
    sums = re.findall(r"=+ (?:ERROR|RACECHECK) SUMMARY: .*", text)
    summary = sums[-1] if sums else ""
    nonzero = [s for s in sums if not re.search(r"SUMMARY: 0 (errors|hazards)", s)]
    if code == 124:
        status = "cut"
    elif "terminated before first instrumented API call" in text:
        status = "no_cuda"  # the run made no CUDA call: nothing for the tool to check (listed, not clean)
    elif nonzero or code == 99:
        status = "errors"
    elif not sums:
        status = "cut"  # no summary: the sanitizer did not finish (killed, crashed)
    elif w["kind"] == "test" and code != 0:
        status = "test_failed"
    else:
        status = "clean"
    rec.update(status=status, summary=summary.strip("= "), exit=code, seconds=round(time.time() - ts, 1))
    if status != "clean":
        d = os.path.join(out, w["tool"], w["target"])
        os.makedirs(d, exist_ok=True)
        with open(os.path.join(d, re.sub(r"[^A-Za-z0-9_.-]", "_", w["name"]) + ".log"), "w") as f:
            # The first report (where the fault starts) and the end (the summary): the reports after the
            # first are mostly its consequences.
            lines = text.splitlines()
            first = next((i for i, l in enumerate(lines) if l.startswith("========= ") and "SUMMARY" not in l
                          and "COMPUTE-SANITIZER" not in l), None)
            head = lines[first:first + 60] if first is not None else []
            f.write(" ".join(cmd) + "\n...\n" + "\n".join(head) + "\n...\n" + "\n".join(lines[-25:]) + "\n")
    return rec

def worker(k):
    gpu = gpus[k % ngpu]
    while True:
        with lock:
            if nxt[0] >= len(work):
                return
            w = work[nxt[0]]
            nxt[0] += 1
        rec = one(w, gpu)
        with lock:
            results.append(rec)
            with open(os.path.join(out, "runs.jsonl"), "a") as f:
                f.write(json.dumps(rec) + "\n")

with open(runs_file, "w") as f:
    for r in earlier:
        f.write(json.dumps(r) + "\n")
threads = [threading.Thread(target=worker, args=(k,)) for k in range(jobs)]
for t in threads:
    t.start()
for t in threads:
    t.join()

# One line per tool x target.
groups = {}
for r in results:
    groups.setdefault((r["tool"], r["target"]), []).append(r)
lines, bad = [], 0
with open(os.path.join(out, "..", "sanitize.jsonl"), "a") as jf:
    for (tool, target), rs in sorted(groups.items()):
        count = {s: [r["name"] for r in rs if r["status"] == s] for s in ("clean", "errors", "test_failed", "cut", "not_run", "no_cuda")}
        ok = len(count["clean"]) == len(rs)
        bad += not ok
        line = f"{tool} {target}: {len(count['clean'])}/{len(rs)} clean"
        for s in ("errors", "test_failed", "cut", "not_run", "no_cuda"):
            if count[s]:
                shown = ", ".join(count[s][:6]) + (f" (+{len(count[s]) - 6})" if len(count[s]) > 6 else "")
                line += f"; {s.replace('_', ' ')} {len(count[s])}: {shown}"
        lines.append(line)
        jf.write(json.dumps(dict(what="sanitizer", tool=tool, target=target, runs=len(rs),
                                 clean=len(count["clean"]), errors=count["errors"], test_failed=count["test_failed"],
                                 cut=count["cut"], not_run=count["not_run"], no_cuda=count["no_cuda"],
                                 device=os.environ.get("LBDEM_DEVICE", ""), commit=os.environ.get("LBDEM_COMMIT", ""),
                                 seconds=round(time.time() - t0))) + "\n")
head = f"# compute-sanitizer sweep: {len(results)} runs ({len(earlier)} clean in an earlier call) on {ngpu} GPUs, {jobs} at once, {round(time.time() - t0)} s"
with open(os.path.join(out, "summary.txt"), "w") as f:
    f.write(head + "\n" + "\n".join(lines) + "\n")
print(head)
print("\n".join(lines))
sys.exit(1 if bad else 0)
PY

"""rost's mutation check (scripts/mutants.sh runs it; the mutants are in scripts/mutants.txt).

Each mutant is a small, realistic bug with the tests expected to catch it. The
source tree is copied into a scratch directory (ROST_MUTANTS_DIR, or one under
/tmp named after the tree), built there once (later runs rebuild incrementally),
and each mutant is applied in the copy, rebuilt, its tests run and the file
restored. The tree the script is run from is only read: it may be a git
checkout or an export without .git.

  mutants.sh             every mutant
  mutants.sh --quick     the three marked quick (the core and two faces; CI runs it)
  mutants.sh --list      the mutants, one a line
  mutants.sh --check     only whether every mutant still applies to the tree
                         (its text found exactly once), without building: CI
                         runs it, so a mutant the code moved away from is named
  mutants.sh NAME...     those mutants
  mutants.sh --in-build DIR [--quick | NAME...]
                         no scratch copy: DIR is an existing build of this tree
                         (CI's build/, already built and tested), each mutant
                         is applied to the tree's own file and restored, and
                         DIR is rebuilt as the tree is at the end. For a
                         throw-away checkout: an interrupted run restores the
                         file it had changed, a killed one (SIGKILL) cannot.

Prints a line per mutant, then `mutants: N, caught: C`; exits 0 only when
every mutant run was caught (a test failed). A mutant whose build targets this
build does not have (no ROS, no Python) is skipped and said so.
"""

import configparser
import hashlib
import os
import re
import shutil
import signal
import subprocess
import sys
import time

ROOT = os.path.realpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
SKIP_TOP = re.compile(r"^(build.*|\.git|data|out)$")


def fail(msg):
    print(f"mutants: error: {msg}", file=sys.stderr)
    sys.exit(2)


def load():
    path = os.path.join(ROOT, "scripts", "mutants.txt")
    cp = configparser.ConfigParser(interpolation=None, comment_prefixes=("#",), inline_comment_prefixes=None)
    cp.optionxform = str
    try:
        with open(path, encoding="utf-8") as f:
            cp.read_file(f)
    except (OSError, configparser.Error) as e:
        fail(f"{path}: {e}")
    out = []
    for name in cp.sections():
        s = cp[name]
        for key in ("file", "find", "replace", "build", "tests", "why"):
            if key not in s:
                fail(f"{path}: [{name}] has no {key}")
        out.append({
            "name": name,
            "file": s["file"],
            "find": s["find"],
            "replace": s["replace"].replace("\\n", "\n"),
            "build": s["build"].split(),
            "tests": s["tests"],
            "quick": s.get("quick", "no") == "yes",
            "why": s["why"],
        })
    return out


def pattern(find):
    # Whitespace in `find` matches any run of whitespace (indentation, line breaks).
    return re.compile(r"\s+".join(re.escape(part) for part in find.split()))


def mutated(text, m):
    hits = list(pattern(m["find"]).finditer(text))
    if len(hits) != 1:
        fail(f"[{m['name']}] {m['file']}: its text occurs {len(hits)} times (exactly once expected); "
             "update scripts/mutants.txt")
    h = hits[0]
    return text[:h.start()] + m["replace"] + text[h.end():]


def read(path):
    with open(path, encoding="utf-8") as f:
        return f.read()


def write(path, text):
    # A fresh modification time, so ninja rebuilds what the previous content built.
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)


def sync(src):
    """The tree into `src`: a file is written only when its content differs, so
    an incremental build rebuilds only what changed since the last run."""
    keep = set()
    for dirpath, dirnames, filenames in os.walk(ROOT):
        rel = os.path.relpath(dirpath, ROOT)
        if rel == ".":
            dirnames[:] = [d for d in dirnames if not SKIP_TOP.match(d)]
            filenames = [f for f in filenames if not SKIP_TOP.match(f)]
        target = os.path.join(src, rel) if rel != "." else src
        os.makedirs(target, exist_ok=True)
        keep.add(os.path.normpath(target))
        for f in filenames:
            a, b = os.path.join(dirpath, f), os.path.join(target, f)
            keep.add(os.path.normpath(b))
            if os.path.islink(a):
                continue
            with open(a, "rb") as fa:
                data = fa.read()
            if os.path.isfile(b):
                with open(b, "rb") as fb:
                    if fb.read() == data:
                        continue
            with open(b, "wb") as fb:
                fb.write(data)
            shutil.copymode(a, b)
    for dirpath, dirnames, filenames in os.walk(src, topdown=False):  # what the tree no longer has
        rel = os.path.relpath(dirpath, src)
        if rel != "." and SKIP_TOP.match(rel.split(os.sep)[0]):
            continue
        for f in filenames:
            p = os.path.normpath(os.path.join(dirpath, f))
            if p not in keep and not (rel == "." and SKIP_TOP.match(f)):
                os.remove(p)
        if rel != "." and os.path.normpath(dirpath) not in keep:
            shutil.rmtree(dirpath, ignore_errors=True)
    data = os.path.join(ROOT, "data")
    link = os.path.join(src, "data")
    if os.path.isdir(data) and not os.path.lexists(link):
        os.symlink(data, link)  # footage the tests read (never written: it is fetched already)


def run(cmd, log, timeout=None):
    with open(log, "a", encoding="utf-8") as f:
        f.write("$ " + " ".join(cmd) + "\n")
        f.flush()
        try:
            return subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                  timeout=timeout).returncode
        except subprocess.TimeoutExpired:
            f.write("(timed out)\n")
            return 124


def tests_matching(build, regex):
    """The numbers of the tests `regex` selects (ctest -N -R), or None when
    CMake's regular expressions cannot compile it (ctest then selects no
    test and still exits 0: about ten groups at most)."""
    p = subprocess.run(["ctest", "--test-dir", build, "-N", "-R", regex], capture_output=True, text=True)
    if "RegularExpression::compile()" in p.stdout + p.stderr:
        return None
    return sorted({int(n) for n in re.findall(r"Test +#(\d+):", p.stdout)})


def built_from(build):
    """The source directory a CMake build was configured from, or None."""
    try:
        with open(os.path.join(build, "CMakeCache.txt"), encoding="utf-8") as f:
            for line in f:
                if line.startswith("CMAKE_HOME_DIRECTORY:"):
                    return os.path.realpath(line.split("=", 1)[1].strip())
    except OSError:
        pass
    return None


def terminated(signum, frame):
    raise SystemExit(128 + signum)  # unwinds through the `finally` that restores a mutated file


def targets_of(build):
    p = subprocess.run(["ninja", "-C", build, "-t", "targets", "all"], capture_output=True, text=True)
    return {line.split(":")[0] for line in p.stdout.splitlines()}


def main(argv):
    mutants = load()
    if "--list" in argv:
        for m in mutants:
            print(f"{m['name']}{' (quick)' if m['quick'] else ''}: {m['file']}: {m['why']}")
        return 0
    in_build = None
    if "--in-build" in argv:
        i = argv.index("--in-build")
        if i + 1 >= len(argv) or argv[i + 1].startswith("--"):
            fail("--in-build needs a build directory")
        in_build = os.path.realpath(argv[i + 1])
        argv = argv[:i] + argv[i + 2:]
    names = [a for a in argv if not a.startswith("--")]
    unknown = [a for a in argv if a.startswith("--") and a not in ("--quick", "--check")]
    if unknown:
        fail(f"unknown option {unknown[0]} (--list, --quick, --check, --in-build DIR, or mutant names)")
    if names:
        known = {m["name"] for m in mutants}
        for n in names:
            if n not in known:
                fail(f"no mutant named {n} (--list lists them)")
        chosen = [m for m in mutants if m["name"] in names]
    elif "--quick" in argv:
        chosen = [m for m in mutants if m["quick"]]
    else:
        chosen = mutants
    originals = {}
    for m in chosen:  # every mutant applies to the tree as it is, before any work
        path = os.path.join(ROOT, m["file"])
        if not os.path.isfile(path):
            fail(f"[{m['name']}] {m['file']}: no such file")
        originals[m["file"]] = read(path)
        mutated(originals[m["file"]], m)
    if "--check" in argv:
        print(f"mutants: all {len(chosen)} apply to the tree (each one's text found exactly once)")
        return 0

    jobs = str(os.cpu_count() or 2)
    if in_build:
        src, build = ROOT, in_build
        if built_from(build) != ROOT:
            fail(f"{build} is not a CMake build of {ROOT} (its CMakeCache.txt names {built_from(build) or 'no source'})")
        log = os.path.join(build, "mutants-log.txt")
        print(f"mutants: {len(chosen)} to run in {build}, on the tree's own files; log {log}", flush=True)
    else:
        scratch = os.environ.get("ROST_MUTANTS_DIR") or os.path.join(
            "/tmp", "rost-mutants-" + hashlib.sha1(ROOT.encode()).hexdigest()[:10])
        src, build, log = (os.path.join(scratch, d) for d in ("src", "build", "log.txt"))
        os.makedirs(scratch, exist_ok=True)
        print(f"mutants: {len(chosen)} to run; scratch copy {src}, build {build}, log {log}", flush=True)
    with open(log, "w", encoding="utf-8"):
        pass
    if not in_build:
        sync(src)
        if run(["cmake", "-S", src, "-B", build, "-G", "Ninja", "-DCMAKE_BUILD_TYPE=Release", "-DROST_VISION=ON",
                "-DROST_BUILD_BENCH=OFF"], log) != 0:
            fail(f"the scratch copy does not configure (see {log})")
    have = targets_of(build)
    runnable, skipped = [], []
    for m in chosen:
        missing = [t for t in m["build"] if t not in have]
        (skipped if missing else runnable).append((m, missing))
    for m, missing in skipped:
        print(f"skipped   {m['name']}: this build has no {' '.join(missing)}", flush=True)
    runnable = [m for m, _ in runnable]
    targets = sorted({t for m in runnable for t in m["build"]})
    t0 = time.time()
    if targets and run(["cmake", "--build", build, "-j", jobs, "--target", *targets], log) != 0:
        fail(f"the unmutated tree does not build (see {log})")
    # The baseline: every test some mutant runs, once, by number (one regex
    # joining the mutants' patterns overflows CMake's regular expressions,
    # and ctest then runs nothing and exits 0).
    union = set()
    for m in runnable:
        numbers = tests_matching(build, m["tests"])
        if numbers is None:
            fail(f"[{m['name']}] ctest cannot compile the pattern {m['tests']}")
        if not numbers:
            fail(f"[{m['name']}] no test matches {m['tests']}")
        union.update(numbers)
    if union and run(["ctest", "--test-dir", build, "-I", "0,0,0," + ",".join(map(str, sorted(union))),
                      "--no-tests=error", "-j", jobs, "--timeout", "300"], log) != 0:
        fail(f"the tests fail without any mutant (see {log})")
    print(f"baseline: built, and its {len(union)} tests passed, in {time.time() - t0:.0f} s", flush=True)

    caught = 0
    for m in runnable:
        t1 = time.time()
        path = os.path.join(src, m["file"])
        original = read(path)
        write(path, mutated(original, m))
        try:
            built = run(["cmake", "--build", build, "-j", jobs, "--target", *m["build"]], log) == 0
            rc = run(["ctest", "--test-dir", build, "-R", m["tests"], "--no-tests=error", "-j", jobs, "--timeout", "300"],
                     log) if built else 0
        finally:
            write(path, original)
        took = time.time() - t1
        if not built:
            print(f"NOT BUILT {m['name']}: the mutant does not compile (see {log}); fix scripts/mutants.txt", flush=True)
        elif rc != 0:
            caught += 1
            print(f"caught    {m['name']} ({took:.0f} s)", flush=True)
        else:
            print(f"SURVIVED  {m['name']}: no test of {m['tests']} failed; {m['why']}", flush=True)
    if in_build:  # the restored files are newer than what the mutants built from them
        t1 = time.time()
        if run(["cmake", "--build", build, "-j", jobs], log) != 0:
            fail(f"{build} does not build again from the restored tree (see {log})")
        print(f"rebuilt   {build} from the restored tree ({time.time() - t1:.0f} s)", flush=True)
    print(f"mutants: {len(runnable)}, caught: {caught}" + (f" ({len(skipped)} skipped)" if skipped else ""))
    return 0 if caught == len(runnable) else 1


if __name__ == "__main__":
    signal.signal(signal.SIGTERM, terminated)
    signal.signal(signal.SIGHUP, terminated)
    sys.exit(main(sys.argv[1:]))

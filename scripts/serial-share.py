#!/usr/bin/python3
"""How much of a `rost refine --threads N` run is serial: one thread working
while the others wait (issue 32, item 1; bench/RESULTS.md, "Item 1, eleventh
session").

The command runs under `perf record` (every thread, a software clock, FREQ
samples a second). A sample is *working* unless it is a worker waiting for
the next job or the caller waiting for the last task (WorkerPool::waitChange,
waitFor); a thread that sleeps takes no sample at all. A working sample with
no working sample of another thread within 0.6 sample periods is serial time.
The serial time is measured where it happens, one thread running alone, so a
machine whose two CPUs are one core's hardware threads, which slows the
parallel parts, still measures it; the parallel parts' time is not
comparable across such machines.

Prints the serial time, its share of the profiled run, the same share of an
unprofiled one-thread run's time (the bar's "serial rest below 5 %"), the
part of it during which another thread was seen waiting (spinning in the
pool: the others truly waited for this one; the rest ran beside threads that
took no sample, which on a guest whose host takes a CPU away at times
need not be serial; before the pool starts no thread spins, so that phase
is serial whatever the column says), and
the functions it is spent in, phase by phase: before the pool's first worker
starts (the process, reading, set-up), while the workers run (ingest,
rounds' tails, measurements), and after the last stops (the files).

Usage: scripts/serial-share.py WORDS.csv POSITIONS.csv [--threads N]
       [--freq HZ] [--rost build/rost]
Needs perf (linux-perf) and a kernel that lets this user profile.
"""

import argparse
import bisect
import collections
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

# A thread waiting: the pool's spins, and libstdc++'s atomic wait (its spin
# and yield before the futex; a thread asleep on the futex takes no sample).
# Only a sample's innermost function is read, so a wait inside the kernel
# (a yield's system call) still counts as work: the serial time is an upper
# bound.
WAITING = ("WorkerPool::waitChange", "WorkerPool::waitFor", "std::__detail::__waiter", "std::__detail::__atomic_",
           "__atomic_wait_address", "__thread_yield", "sched_yield")


def run_timed(cmd):
    start = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - start


def samples(perf_data):
    """(tid, time, symbol) of every sample, in time order."""
    out = subprocess.run(["perf", "script", "-i", perf_data, "-F", "tid,time,ip,sym"],
                         check=True, capture_output=True, text=True).stdout
    demangled = subprocess.run(["c++filt"], input=out, check=True, capture_output=True, text=True).stdout
    rows = []
    for line in demangled.splitlines():
        m = re.match(r"\s*(\d+)\s+([\d.]+):\s+[0-9a-f]+\s+(.*)", line)
        if m:
            rows.append((int(m.group(1)), float(m.group(2)), m.group(3).strip()))
    rows.sort(key=lambda r: r[1])
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("words", help="WORDS.csv of the stream")
    ap.add_argument("positions", help="POSITIONS.csv of the same observations")
    ap.add_argument("--threads", type=int, default=2, help="threads of the profiled run (default 2)")
    ap.add_argument("--freq", type=int, default=2000, help="samples a second of each thread (default 2000)")
    ap.add_argument("--rost", default="build/rost", help="the rost binary (default build/rost)")
    a = ap.parse_args()
    for tool in ("perf", "c++filt"):
        if shutil.which(tool) is None:
            print(f"serial-share: {tool} not found (apt-get install -y linux-perf binutils)", file=sys.stderr)
            return 1
    if not os.access(a.rost, os.X_OK):
        print(f"serial-share: {a.rost}: not an executable rost (build it, or give --rost)", file=sys.stderr)
        return 1

    with tempfile.TemporaryDirectory() as tmp:
        def command(threads, out):
            return [a.rost, "refine", a.words, "--positions", a.positions, "--out", os.path.join(tmp, out),
                    "--threads", str(threads), "-q"]
        one = sorted(run_timed(command(1, "one")) for _ in range(3))[1]
        wall = sorted(run_timed(command(a.threads, "n")) for _ in range(3))[1]
        data = os.path.join(tmp, "perf.data")
        subprocess.run(["perf", "record", "-q", "-e", "cpu-clock", "-F", str(a.freq), "-o", data, "--"]
                       + command(a.threads, "p"), check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        rows = samples(data)
    if len(rows) < 2:
        print("serial-share: perf recorded no samples (is perf allowed here? see perf_event_paranoid)", file=sys.stderr)
        return 1

    main_tid = rows[0][0]
    period = 1.0 / a.freq
    window = 0.6 * period
    working = [(tid, t, s) for tid, t, s in rows if not any(w in s for w in WAITING)]
    by_thread = collections.defaultdict(list)
    for tid, t, _ in working:
        by_thread[tid].append(t)

    waiting_by_thread = collections.defaultdict(list)
    for tid, t, s in rows:
        if any(w in s for w in WAITING):
            waiting_by_thread[tid].append(t)

    def near(times, t):
        i = bisect.bisect_left(times, t - window)
        return i < len(times) and times[i] <= t + window

    def others_working(tid, t):
        return any(near(times, t) for other, times in by_thread.items() if other != tid)

    def others_waiting(tid, t):
        return any(near(times, t) for other, times in waiting_by_thread.items() if other != tid)

    # The phases: the calling thread before the first sample of a worker
    # thread (a thread whose samples include the pool's waits), while one
    # runs, after the last.
    pool_threads = {tid for tid, _, s in rows if tid != main_tid and any(w in s for w in WAITING)}
    pool_times = [t for tid, t, _ in rows if tid in pool_threads]
    first_pool, last_pool = (min(pool_times), max(pool_times)) if pool_times else (float("inf"), float("-inf"))

    def phase(t):
        return "before the pool" if t < first_pool else ("after the pool" if t > last_pool else "with the pool")

    serial = collections.Counter()
    serial_phase = collections.Counter()
    n_serial = 0
    waited_phase = collections.Counter()
    waited = collections.Counter()
    n_waited = 0  # serial samples while another thread was seen waiting for this one
    for tid, t, s in working:
        if not others_working(tid, t):
            n_serial += 1
            if others_waiting(tid, t):
                n_waited += 1
                waited_phase[phase(t)] += 1
                waited[(phase(t), ("caller" if tid == main_tid else "worker") + ": " + s)] += 1
            who = "caller" if tid == main_tid else ("worker" if tid in pool_threads else "helper")
            serial[(phase(t), who + ": " + s)] += 1
            serial_phase[phase(t)] += 1
    span = rows[-1][1] - rows[0][1]
    serial_s = n_serial * period
    share = serial_s / span
    print(f"rost refine --threads {a.threads}: {wall:.3f} s (median of 3, not profiled); "
          f"--threads 1: {one:.3f} s")
    print(f"profiled at {a.freq} Hz: {span:.3f} s, {len(rows)} samples, {len(by_thread)} threads working")
    print(f"serial (one thread working alone): {serial_s * 1000:.1f} ms profiled, {share * 100:.1f} % of the run;")
    print(f"  scaled to the unprofiled run: {share * wall * 1000:.1f} ms, {share * wall / one * 100:.1f} % of "
          f"the one-thread run's {one:.3f} s")
    waited_s = n_waited * period
    print(f"  of it, another thread seen waiting: {waited_s * 1000:.1f} ms profiled "
          f"({waited_s / span * wall / one * 100:.1f} % of the one-thread run); the rest ran beside a thread that "
          f"took no sample (asleep, not started yet, or its CPU taken by the host)")
    for p in ("before the pool", "with the pool", "after the pool"):
        print(f"  {p}: {serial_phase[p] * period * 1000:.1f} ms profiled, {waited_phase[p] * period * 1000:.1f} ms "
              f"of it with another thread seen waiting; where (samples of "
              f"{period * 1000:.2f} ms; caller, a pool worker or a helper thread: reader, zeroer, summary; the second column: samples with another thread seen waiting):")
        for (q, s), c in serial.most_common():
            if q == p and c >= 2:
                print(f"    {c:6d} {waited[(q, s)]:6d}  {s[:110]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

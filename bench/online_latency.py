#!/usr/bin/env python3
"""The delay of `topics.refine.t --online` (issue 28, item 5): documents written to its standard
input one every 0.5 s, the time from a document's write until its line is in perplexity.online.csv
(polled every millisecond). Prints the minimum, median and maximum in ms.

  python3 bench/online_latency.py --bin build/bin/topics.refine.t --mint 50 --documents 20
"""

import argparse
import os
import subprocess
import tempfile
import time


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bin", default="build/bin/topics.refine.t")
    ap.add_argument("--mint", type=int, default=50)
    ap.add_argument("--documents", type=int, default=20)
    ap.add_argument("--pace", type=float, default=0.5)
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as out:
        p = subprocess.Popen([os.path.abspath(a.bin), "-i", "-", "-V", "40", "-K", "4", "--online", "--online.mint",
                              str(a.mint), "--threads", "1"], stdin=subprocess.PIPE, cwd=out)
        online = os.path.join(out, "perplexity.online.csv")
        delays = []
        for i in range(a.documents):
            t0 = time.monotonic()
            p.stdin.write(f"{i}.50,{','.join(str((i * 3 + k) % 40) for k in range(24))}\n".encode())
            p.stdin.flush()
            while True:
                try:
                    with open(online) as f:
                        n = f.read().count("\n")
                except FileNotFoundError:
                    n = 0
                if n > i:
                    break
                time.sleep(0.001)
            delays.append((time.monotonic() - t0) * 1000)
            time.sleep(a.pace)
        p.stdin.close()
        rc = p.wait()
    delays.sort()
    print(f"exit {rc}; {len(delays)} documents, --online.mint {a.mint}: delay min {delays[0]:.1f} ms, "
          f"median {delays[len(delays) // 2]:.1f} ms, max {delays[-1]:.1f} ms")


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Runs every scenario file of a corpus (fuzz/corpus.py) through `formica check` and a short
`formica run`, and fails unless each ends with exit 0, or exit 2 with a `file:line:column`
error, within the time and memory bounds: never a panic (exit 101), an abort, a signal, a hang
or more memory.

    python3 fuzz/run-corpus.py FORMICA_BIN CORPUS_DIR [--jobs 2] [--seconds 10] [--mib 1024]

Memory: each command runs with its address space limited to the bound (RLIMIT_AS; going past
it makes an allocation fail, which aborts), and its peak resident size is measured too.
"""

import argparse
import concurrent.futures
import os
import pathlib
import re
import resource
import signal
import subprocess
import sys
import time

POSITION = re.compile(r"^error: .*?:\d+:\d+: ", re.M)


def run_one(binary, args, seconds, mib):
    """(exit code or -signal, stderr, seconds taken, timed out)."""
    limit = mib << 20

    def limits():
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
        os.setsid()

    t0 = time.monotonic()
    p = subprocess.Popen(
        [binary, *args],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        preexec_fn=limits,
    )
    timed_out = False
    try:
        _, err = p.communicate(timeout=seconds)
    except subprocess.TimeoutExpired:
        timed_out = True
        os.killpg(p.pid, signal.SIGKILL)
        _, err = p.communicate()
    return p.returncode, err.decode("utf-8", "replace"), time.monotonic() - t0, timed_out


def check_file(binary, path, seconds, mib, duration):
    """Problems with one file (empty when all is well), and its two timings."""
    problems, times, codes = [], [], []
    for args in (["check", str(path)], ["run", str(path), "--duration", duration]):
        code, err, took, timed_out = run_one(binary, args, seconds, mib)
        times.append(took)
        codes.append((args[0], code))
        what = f"formica {args[0]} {path.name}"
        if timed_out:
            problems.append(f"{what}: took more than {seconds} s")
        elif code == 2:
            if not POSITION.search(err):
                problems.append(f"{what}: exit 2 without file:line:column: {err.strip()[:300]}")
        elif code != 0:
            problems.append(f"{what}: exit {code}: {err.strip()[-500:]}")
    return problems, times, codes


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("binary")
    ap.add_argument("corpus", type=pathlib.Path)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--mib", type=int, default=1024)
    ap.add_argument("--duration", default="0.5", help="simulated seconds of each run")
    a = ap.parse_args()
    binary = str(pathlib.Path(a.binary).resolve())
    files = sorted(a.corpus.glob("*.toml"))
    if not files:
        sys.exit(f"no .toml files in {a.corpus}")
    t0 = time.monotonic()
    problems, slowest, tally = [], (0.0, ""), {}
    with concurrent.futures.ThreadPoolExecutor(a.jobs) as pool:
        futures = {
            pool.submit(check_file, binary, f, a.seconds, a.mib, a.duration): f for f in files
        }
        for fut in concurrent.futures.as_completed(futures):
            p, times, codes = fut.result()
            problems += p
            for c in codes:
                tally[c] = tally.get(c, 0) + 1
            if max(times) > slowest[0]:
                slowest = (max(times), futures[fut].name)
    # The largest peak resident size of any command run (Linux gives KiB).
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss >> 10
    print(
        f"corpus: {len(files)} files x 2 commands in {time.monotonic() - t0:.0f} s, "
        f"slowest {slowest[0]:.2f} s ({slowest[1]}), largest peak resident size {peak} MiB "
        f"(bounds: {a.seconds:g} s, {a.mib} MiB)"
    )
    print("exits:", ", ".join(f"{cmd} {code}: {n}" for (cmd, code), n in sorted(tally.items())))
    for p in sorted(problems):
        print("FAIL", p)
    if peak > a.mib:
        print(f"FAIL a command's peak resident size was {peak} MiB")
        problems.append("memory")
    print(f"{len(files) * 2 - len(problems)} passed, {len(problems)} failed")
    sys.exit(1 if problems else 0)


if __name__ == "__main__":
    main()

# SPDX-License-Identifier: Apache-2.0
"""Signal sweep by hand (issue 27.2): SENDS runs of a command on an example, each sent SIGINT,
SIGTERM or SIGHUP after a random delay (fixed seed), to the process or to its process group (as a
terminal's Ctrl-C and hang-up do). The commands: validate, render (native), render with the
POV-Ray backend, compile, diff, and render --frames on a two-worker Dask LocalCluster.

A run passes when it ends with exit 0 (done before the signal) or 130 / 143 / 129, at most one
stderr line besides the commands' own status lines ("native: rendered in 0.12 s"), no traceback,
no output left behind when it did not finish (but --frames' finished frames, each written whole), nothing left in its TMPDIR, and no process of
its own still alive a moment after it ended (POV-Ray, the sandbox child, Dask's scheduler, nanny
and workers: found by a marker in their environment). Every failing run is printed.

    .venv/bin/python benchmarks/signal_sweep.py SENDS [SEED] [--max-delay S] [--command PATH]

``--command``: the program to run (default: .venv/bin/phongscene); e.g. a Python console script
made by hand, to compare with the C launcher (cli/launcher.c) at short delays."""

import argparse
import collections
import glob
import os
import random
import re
import shutil
import signal
import subprocess
import tempfile
import time
from pathlib import Path

EXPECTED = {signal.SIGINT: 130, signal.SIGTERM: 143, signal.SIGHUP: 129}
SCENE = "examples/seed_exponents.usda"
STATUS_LINE = re.compile(r"^([\w ]+: \w+ in [\d.]+ s|frames? .*|\s*\d+ of \d+.*|report: .*)$")
# --frames writes each frame atomically as it finishes (and --skip-existing resumes from them):
# the frames done before the signal stay, whole; anything else left is a partial output.
WHOLE_FRAME = re.compile(r"^f\d{4}\.png$")
# A process of the run still alive this long after it ended is an orphan (Dask's workers are
# told to go as the cluster closes; they need a moment to exit).
ORPHAN_GRACE_S = 5.0


def commands(out: str) -> dict[str, list[str]]:
    return {
        "validate": ["validate", SCENE],
        "render": ["render", SCENE, "-o", f"{out}/o.png", "--width", "32"],
        "render-povray": ["render", SCENE, "-o", f"{out}/o.png", "--width", "32", "--backend", "povray"],
        "compile": ["compile", SCENE, "-o", f"{out}/o.pov"],
        "diff": ["diff", SCENE, "-o", f"{out}/report", "--width", "24"],
        "frames": ["render", SCENE, "-o", f"{out}/f####.png", "--width", "16", "--frames", "1:4", "--workers", "2"],
    }


def processes_with(marker: str) -> list[int]:
    found = []
    for environ in glob.glob("/proc/[0-9]*/environ"):
        try:
            if marker.encode() in Path(environ).read_bytes():
                found.append(int(environ.split("/")[2]))
        except OSError:
            continue
    return found


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("sends", type=int)
    parser.add_argument("seed", type=int, nargs="?", default=1)
    parser.add_argument("--max-delay", type=float, default=1.5, help="longest delay before the signal (s)")
    parser.add_argument("--command", default=".venv/bin/phongscene")
    parser.add_argument("--only", help="one command of the list (default: a random one per send)")
    args = parser.parse_args()
    rng = random.Random(args.seed)
    root = tempfile.mkdtemp(prefix="phongscene_sweep_")
    tally: collections.Counter = collections.Counter()
    bad = []
    start = time.monotonic()
    for i in range(args.sends):
        out, tmp = f"{root}/out{i}", f"{root}/tmp{i}"
        os.makedirs(out)
        os.makedirs(tmp)
        table = commands(out)
        name = args.only or rng.choice(sorted(table))
        sig = rng.choice(list(EXPECTED))
        group = rng.random() < 0.5
        delay = rng.uniform(0, args.max_delay)
        marker = f"PHONGSCENE_SWEEP_RUN={os.getpid()}_{i}"
        env = dict(os.environ, TMPDIR=tmp, PHONGSCENE_SWEEP_RUN=marker.split("=", 1)[1])
        p = subprocess.Popen(
            [args.command, *table[name]],
            stderr=subprocess.PIPE,
            stdout=subprocess.DEVNULL,
            stdin=subprocess.DEVNULL,
            env=env,
            start_new_session=True,  # its own group, so a group send reaches only the run
        )
        time.sleep(delay)
        try:
            os.killpg(p.pid, sig) if group else p.send_signal(sig)
        except ProcessLookupError:
            pass
        _, err = p.communicate(timeout=300)
        err = err.decode(errors="replace")
        problems = []
        said = [line for line in err.splitlines() if not STATUS_LINE.match(line)]
        if p.returncode not in (0, EXPECTED[sig]):
            problems.append(f"exit {p.returncode}")
        if "Traceback" in err or len(said) > 1:
            problems.append("output")
        left = os.listdir(out)
        if name == "frames":  # each frame is written whole (atomically): only partial files count
            left = [f for f in left if not WHOLE_FRAME.match(f)]
        if p.returncode != 0 and left:
            problems.append(f"left {left}")
        deadline = time.monotonic() + ORPHAN_GRACE_S
        while (alive := processes_with(marker)) and time.monotonic() < deadline:
            time.sleep(0.1)
        if alive:
            problems.append(f"orphans {alive}")
            for pid in alive:
                try:
                    os.kill(pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
        if os.listdir(tmp):
            problems.append(f"TMPDIR {os.listdir(tmp)}")
        how = "group" if group else "process"
        tally[(name, signal.Signals(sig).name, how, p.returncode)] += 1
        if problems:
            bad.append((name, signal.Signals(sig).name, how, round(delay, 3), problems, err[-400:]))
            print("FAIL", bad[-1], flush=True)
        shutil.rmtree(out, ignore_errors=True)
        shutil.rmtree(tmp, ignore_errors=True)
    shutil.rmtree(root, ignore_errors=True)
    print(f"{args.sends} sends (seed {args.seed}, delays 0-{args.max_delay} s) in {time.monotonic() - start:.0f} s")
    by_command = collections.Counter()
    for (name, _sig, _how, code), count in tally.items():
        by_command[(name, code)] += count
    for (name, code), count in sorted(by_command.items()):
        print(f"  {name:14s} exit {code:4d}: {count}")
    print(f"{len(bad)} failing runs")


if __name__ == "__main__":
    main()

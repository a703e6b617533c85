# SPDX-License-Identifier: Apache-2.0
"""Signal sweep by hand (issue 27.2): SENDS runs of validate / render / compile on an example, each
sent SIGINT, SIGTERM or SIGHUP after a random delay in [0, 1.5) s (fixed seed). A run passes with
exit 0 (done before the signal) or 130 / 143 / 129, at most one stderr line besides the command's
own status line ("native: rendered in 0.12 s"), no traceback, and no output left behind when it did
not finish. Every failing run is printed.

    .venv/bin/python benchmarks/signal_sweep.py SENDS [SEED]
"""

import collections
import glob
import os
import random
import re
import signal
import subprocess
import sys
import tempfile
import time

OUT = tempfile.mkdtemp(prefix="phongscene_sweep_")
rng = random.Random(int(sys.argv[2]) if len(sys.argv) > 2 else 1)
N = int(sys.argv[1])
EXP = {signal.SIGINT: 130, signal.SIGTERM: 143, signal.SIGHUP: 129}
tally = collections.Counter()
bad = []
for _i in range(N):
    sig = rng.choice(list(EXP))
    delay = rng.uniform(0, 1.5)
    cmd = rng.choice(
        [
            ["validate", "examples/seed_exponents.usda"],
            ["render", "examples/seed_exponents.usda", "-o", OUT + "/o.png", "--width", "32"],
            ["compile", "examples/seed_exponents.usda", "-o", OUT + "/o.pov"],
        ]
    )
    os.makedirs(OUT + "", exist_ok=True)
    for f in glob.glob(OUT + "/*"):
        os.unlink(f)
    p = subprocess.Popen([".venv/bin/phongscene", *cmd], stderr=subprocess.PIPE, stdout=subprocess.DEVNULL)
    time.sleep(delay)
    p.send_signal(sig)
    _, err = p.communicate(timeout=60)
    err = err.decode(errors="replace")
    said = [line for line in err.splitlines() if not re.match(r"^\w+: rendered in [\d.]+ s$", line)]
    ok = p.returncode in (0, EXP[sig]) and "Traceback" not in err and len(said) <= 1
    left = glob.glob(OUT + "/*")
    if p.returncode != 0 and left:
        ok = False
    tally[(signal.Signals(sig).name, p.returncode)] += 1
    if not ok:
        bad.append((cmd[0], signal.Signals(sig).name, round(delay, 3), p.returncode, err[-300:], left))
print(N, "sends", dict(tally))
print(len(bad), "bad")
for b in bad:
    print(b)

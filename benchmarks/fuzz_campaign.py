# SPDX-License-Identifier: Apache-2.0
"""A mutation campaign by hand (issue 27.5): N corrupt copies of the seed files (truncated,
bit-flipped, bytes overwritten / inserted / deleted / duplicated; .usda, .usdc, .usdz), each
through every command (validate, render, info, compile), two child processes at a time. Every
run must end in exit 0/2/3 with at most a few ``error:`` / ``warning:`` lines, within the time
limit, and leave no output behind on failure (the checks of tests/cli/test_fuzz_files.py).

    .venv/bin/python benchmarks/fuzz_campaign.py --files 5000 [--seed 1] [--minutes 60] [--first K]

Each file is drawn from (seed, index) alone, so a campaign can run in parts: ``--first 2000
--files 3000`` is files 2000-4999 of the same seed.

Prints the exit codes per command, and every failure (file kept in --keep) as it happens."""

from __future__ import annotations

import argparse
import random
import shutil
import sys
import tempfile
import time
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(REPO / "tests"), str(REPO / "tests" / "cli")]
from test_fuzz_files import COMMANDS, _seeds, check_clear_answer, mutate, run_command  # noqa: E402


def random_edits(rng: random.Random, size: int):
    """1-3 edits, as the test's Hypothesis strategy draws them, plus single bit flips."""
    edits = []
    for _ in range(rng.randint(1, 3)):
        kind = rng.choice(["overwrite", "insert", "delete", "duplicate", "truncate", "bitflip"])
        where = rng.random()
        if kind == "bitflip":
            edits.append(("bitflip", where, 1 << rng.randrange(8)))
        elif kind in ("overwrite", "insert"):
            edits.append((kind, where, bytes(rng.randrange(256) for _ in range(rng.randint(1, 16)))))
        else:
            edits.append((kind, where, rng.randint(1, 4096)))
    return edits


def apply(data: bytes, edits) -> bytes:
    for kind, where, arg in edits:
        if kind == "bitflip":
            if data:
                at = min(int(where * len(data)), len(data) - 1)
                data = data[:at] + bytes([data[at] ^ arg]) + data[at + 1 :]
        else:
            data = mutate(data, [(kind, where, arg)])
    return data


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--files", type=int, default=5000)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--first", type=int, default=0, help="index of the first file (to run a campaign in parts)")
    parser.add_argument("--minutes", type=float, default=float("inf"), help="stop after this long")
    parser.add_argument("--keep", type=Path, default=Path("out/fuzz_failures"), help="failing files go here")
    args = parser.parse_args()
    root = Path(tempfile.mkdtemp(prefix="phongscene_fuzz_"))
    try:
        seeds = _seeds(root)
        codes: dict[str, Counter] = {c[0]: Counter() for c in COMMANDS}
        failures, runs, start = 0, 0, time.monotonic()
        slowest = 0.0

        def one(i: int):
            rng = random.Random(f"{args.seed}-{i}")  # per file: the same files whatever the threads' order
            original = seeds[rng.randrange(len(seeds))]
            path = root / f"m{i}_{original.name}"
            path.write_bytes(apply(original.read_bytes(), random_edits(rng, len(original.read_bytes()))))
            results = []
            for command in COMMANDS:
                out = root / f"out{i}_{command[0]}"
                out.mkdir()
                t0 = time.monotonic()
                try:
                    result = run_command(path, command, out)
                    problem = None
                    check_clear_answer(path, result)
                    if result.returncode != 0 and list(out.iterdir()):
                        problem = f"left {list(out.iterdir())}"
                except AssertionError as e:
                    result, problem = None, str(e)[:500]
                except Exception as e:
                    result, problem = None, f"{type(e).__name__}: {e}"
                results.append((command[0], result, problem, time.monotonic() - t0))
                shutil.rmtree(out, ignore_errors=True)
            return path, results

        with ThreadPoolExecutor(max_workers=2) as pool:
            pending = [pool.submit(one, i) for i in range(args.first, args.first + args.files)]
            for future in pending:
                if time.monotonic() - start > args.minutes * 60:
                    for p in pending:
                        p.cancel()
                    break
                path, results = future.result()
                for name, result, problem, seconds in results:
                    runs += 1
                    slowest = max(slowest, seconds)
                    codes[name][result.returncode if result is not None else "bad"] += 1
                    if problem:
                        failures += 1
                        args.keep.mkdir(parents=True, exist_ok=True)
                        shutil.copy(path, args.keep / path.name)
                        print(f"FAIL {name} {path.name}: {problem}", flush=True)
                path.unlink(missing_ok=True)
                if runs % (250 * len(COMMANDS)) == 0:
                    print(
                        f"  {runs // len(COMMANDS)} files, {failures} failures, {time.monotonic() - start:.0f} s",
                        flush=True,
                    )
        files = runs // len(COMMANDS)
        print(
            f"files {args.first}-{args.first + files - 1} (seed {args.seed}): {files} files x {len(COMMANDS)} commands = {runs} runs in {time.monotonic() - start:.0f} s, "
            f"{failures} failures, slowest run {slowest:.1f} s (limit {60} s)"
        )
        for name, counter in codes.items():
            print(f"  {name:9s} " + ", ".join(f"exit {k}: {v}" for k, v in sorted(counter.items(), key=str)))
        return 1 if failures else 0
    finally:
        shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    raise SystemExit(main())

# SPDX-License-Identifier: Apache-2.0
"""Warning sweep over public USD files (issue 28): every scene file under the given folders
through ``phongscene info``, ``render`` (native, 48 pixels wide) and ``compile``, one child process
at a time, each with a time limit. For each run it counts the lines on stdout + stderr that are
warnings: phongscene's own ``warning:`` lines and any diagnostic USD or Python prints itself
("Warning: in ... -- ...", "Coding Error: ...", "Runtime Error: ...", their " -- " and "at line"
continuation lines, "...Warning:" from Python's warnings module). ``render`` and ``compile`` must
print at most ``LIMIT`` such lines (warning_groups.MAX_WARNING_LINES); ``info`` lists every warning
and is reported apart.

    .venv/bin/python benchmarks/warning_sweep.py /work/sweep_files/usd-wg+assets [more folders or files]
    .venv/bin/python benchmarks/warning_sweep.py --list ROOT > files.txt      # the files, one a line
    .venv/bin/python benchmarks/warning_sweep.py --files-from files.txt --first 100 --limit 50

Scene files are .usd, .usda, .usdc and .usdz (not under a 'cards' or 'thumbnails' folder, and no
.usdz over ``MAX_USDZ_MB``), in sorted order, so ``--first``/``--limit`` cut the same parts every
time. Prints a row per run (file, command, exit status, warning lines, seconds; "timeout" for a
run over the limit, "traceback" when one was printed), then a summary: files, the most warning
lines per command, the runs over ``LIMIT``, tracebacks and time-outs. ``--logs DIR`` keeps each
run's whole output; ``--json FILE`` appends each run as a JSON line (to merge runs made in parts).
Exit 1 when a render or compile run prints more than ``LIMIT`` warning lines, prints a traceback
or times out."""

from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
SCENE_SUFFIXES = (".usd", ".usda", ".usdc", ".usdz")
# Folders of a public set that hold no scenes of their own (usd-wg's card images and thumbnails).
SKIPPED_FOLDERS = {"cards", "thumbnails"}
# Bigger packages are left out: reading one takes minutes and most of the machine's memory.
MAX_USDZ_MB = 200
# Each command's time limit (a hang shows as "timeout").
TIMEOUT_S = 120.0
# The most warning lines render and compile may print (phongscene.warning_groups.MAX_WARNING_LINES).
LIMIT = 20
COMMANDS = ("info", "render", "compile")
# A warning-ish line: phongscene's own, USD's diagnostics (TfDiagnosticMgr's default output and its
# continuation lines), Python's warnings module.
WARNING_LINE = re.compile(
    r"^(warning:"
    r"|(Warning|Coding Error|Runtime Error|Fatal Error|Error|Status)\b[^:]*: "
    r"|\s*-- "
    r"|\s*(in \S+ )?at line \d+ of "
    r"|\S*Warning: "
    r"|\s+warnings\.warn)"
)
TRACEBACK = "Traceback (most recent call last):"


def scene_files(roots: list[Path]) -> list[Path]:
    """Every scene file under ``roots`` (a root may be a file), sorted, without card images,
    thumbnails and huge packages."""
    found: set[Path] = set()
    for root in roots:
        candidates = [root] if root.is_file() else root.rglob("*")
        for path in candidates:
            if not path.is_file() or path.suffix.lower() not in SCENE_SUFFIXES:
                continue
            if SKIPPED_FOLDERS & {part.lower() for part in path.parts}:
                continue
            if path.suffix.lower() == ".usdz" and path.stat().st_size > MAX_USDZ_MB * 2**20:
                continue
            found.add(path)
    return sorted(found)


def command_line(phongscene: str, command: str, scene: Path, out: Path) -> list[str]:
    if command == "info":
        return [phongscene, "info", str(scene)]
    if command == "render":
        return [phongscene, "render", str(scene), "--width", "48", "-o", str(out / "o.png")]
    return [phongscene, "compile", str(scene), "-o", str(out / "o.pov")]


def run(phongscene: str, command: str, scene: Path, timeout: float) -> dict:
    """One run: its exit status (or "timeout"), its warning lines, whether it printed a
    traceback, its whole output and how long it took."""
    out = Path(tempfile.mkdtemp(prefix="phongscene_warnings_"))
    start = time.monotonic()
    try:
        done = subprocess.run(
            command_line(phongscene, command, scene, out),
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,  # one stream, in the order printed
            timeout=timeout,
            cwd=out,
        )
        status, output = done.returncode, done.stdout.decode("utf-8", "replace")
    except subprocess.TimeoutExpired as e:
        status, output = "timeout", (e.output or b"").decode("utf-8", "replace")
    finally:
        shutil.rmtree(out, ignore_errors=True)
    lines = output.splitlines()
    warnings = [line for line in lines if WARNING_LINE.match(line)]
    return {
        "file": str(scene),
        "command": command,
        "status": status,
        "warning_lines": len(warnings),
        "traceback": TRACEBACK in output,
        "seconds": round(time.monotonic() - start, 2),
        "warnings": warnings,
        "output": output,
    }


def failed(result: dict, limit: int) -> bool:
    """A render or compile run that prints too much, prints a traceback, or hangs."""
    if result["command"] == "info":
        return result["traceback"] or result["status"] == "timeout"
    return result["warning_lines"] > limit or result["traceback"] or result["status"] == "timeout"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("roots", nargs="*", type=Path, metavar="ROOT", help="folders (searched) or scene files")
    parser.add_argument("--files-from", type=Path, metavar="LIST", help="scene files, one a line (after ROOTs)")
    parser.add_argument("--first", type=int, default=0, help="index of the first file to run (default 0)")
    parser.add_argument("--limit", type=int, default=None, help="run at most this many files")
    parser.add_argument("--list", action="store_true", help="print the scene files, one a line, and stop")
    parser.add_argument(
        "--commands", default=",".join(COMMANDS), help=f"comma-separated, of {', '.join(COMMANDS)} (default: all)"
    )
    parser.add_argument("--timeout", type=float, default=TIMEOUT_S, help=f"seconds per run (default {TIMEOUT_S:g})")
    parser.add_argument(
        "--max-lines", type=int, default=LIMIT, help=f"warning lines render/compile may print (default {LIMIT})"
    )
    parser.add_argument(
        "--phongscene", default=str(REPO / ".venv" / "bin" / "phongscene"), help="the command (default: .venv's)"
    )
    parser.add_argument("--logs", type=Path, metavar="DIR", help="keep each run's whole output here")
    parser.add_argument("--json", type=Path, metavar="FILE", help="append each run as a JSON line here")
    parser.add_argument("--worst", type=int, default=5, help="print the warning lines of the N worst runs")
    args = parser.parse_args()

    files = scene_files(args.roots)
    if args.files_from:
        files += [Path(line.strip()) for line in args.files_from.read_text().splitlines() if line.strip()]
    if not files:
        parser.error("no scene files: give ROOT folders or --files-from")
    files = files[args.first : None if args.limit is None else args.first + args.limit]
    if args.list:
        print("\n".join(map(str, files)))
        return 0
    commands = [c for c in args.commands.split(",") if c]
    if unknown := set(commands) - set(COMMANDS):
        parser.error(f"unknown commands: {', '.join(sorted(unknown))}")
    if args.logs:
        args.logs.mkdir(parents=True, exist_ok=True)

    results: list[dict] = []
    width = min(90, max(len(str(f)) for f in files))
    print(f"{'file':{width}s}  {'command':8s} {'exit':>7s} {'lines':>6s} {'seconds':>8s}", flush=True)
    start = time.monotonic()
    for index, scene in enumerate(files, start=args.first):
        for command in commands:
            result = run(args.phongscene, command, scene, args.timeout)
            results.append(result)
            mark = " traceback" if result["traceback"] else ""
            if command != "info" and result["warning_lines"] > args.max_lines:
                mark += f" OVER {args.max_lines}"
            name = str(scene) if len(str(scene)) <= width else "..." + str(scene)[-width + 3 :]
            print(
                f"{name:{width}s}  {command:8s} {result['status']!s:>7s} {result['warning_lines']:6d} "
                f"{result['seconds']:8.1f}{mark}",
                flush=True,
            )
            if args.logs:
                (args.logs / f"{index:04d}_{scene.name}.{command}.log").write_text(result["output"])
            if args.json:
                with args.json.open("a") as stream:
                    record = {k: v for k, v in result.items() if k != "output"} | {"index": index}
                    stream.write(json.dumps(record) + "\n")

    print(
        f"\n{len(files)} files (index {args.first}-{args.first + len(files) - 1}), {len(results)} runs "
        f"in {time.monotonic() - start:.0f} s"
    )
    for command in commands:
        mine = [r for r in results if r["command"] == command]
        most = max(mine, key=lambda r: r["warning_lines"])
        over = sum(r["warning_lines"] > args.max_lines for r in mine)
        statuses: dict = {}
        for r in mine:
            statuses[r["status"]] = statuses.get(r["status"], 0) + 1
        print(
            f"  {command:8s} max {most['warning_lines']} warning lines ({Path(most['file']).name}); "
            f"{over} files over {args.max_lines}{' (info lists them all: not a failure)' if command == 'info' else ''}; "
            f"{sum(r['traceback'] for r in mine)} tracebacks; "
            + ", ".join(f"exit {k}: {v}" for k, v in sorted(statuses.items(), key=str))
        )
    worst = sorted((r for r in results if r["command"] != "info"), key=lambda r: -r["warning_lines"])
    for r in worst[: args.worst]:
        if not r["warning_lines"]:
            break
        print(f"\n{r['file']} ({r['command']}): {r['warning_lines']} warning lines")
        for line in r["warnings"][: LIMIT + 5]:
            print(f"    {line[:200]}")
    return 1 if any(failed(r, args.max_lines) for r in results) else 0


if __name__ == "__main__":
    raise SystemExit(main())

# SPDX-License-Identifier: Apache-2.0
"""Signals and time limits (issue 10 item 4, issue 11): SIGTERM / SIGHUP during a POV-Ray render
or its half of ``diff`` kill POV-Ray, remove its temporary folder and exit 128 + the signal; a
stopped POV-Ray is abandoned after ``--timeout`` (exit 3); Ctrl-C while USD's Python modules are
imported exits 130 (USD's import machinery used to swallow it)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from phongscene.cli import EXIT_BACKEND, EXIT_INTERRUPTED
from support.paths import REPO

SCENE = REPO / "examples" / "seed_exponents.usda"
PHONGSCENE = Path(sys.executable).with_name("phongscene")
# 1600 x 1200 keeps POV-Ray busy for ~1 s after it starts (ref §17), long enough to signal it.
BUSY_WIDTH = "1600"
# How long a test waits for POV-Ray to start, or for phongscene to exit after a signal: generous,
# for a loaded 2-core machine; a hang fails instead of blocking the suite.
WAIT_SECONDS = 60


def _children(pid: int) -> list[int]:
    try:
        text = Path(f"/proc/{pid}/task/{pid}/children").read_text()
    except OSError:
        return []
    return [int(c) for c in text.split()]


def _command(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/comm").read_text().strip()
    except OSError:
        return ""


def _alive(pid: int) -> bool:
    """The process exists and is not a zombie waiting to be reaped."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


def _start(tmp_path: Path, args: list[str]) -> tuple[subprocess.Popen, int, Path]:
    """Start phongscene with its temporary files under tmp_path/tmp; wait until POV-Ray runs.
    Returns the process, POV-Ray's pid and the temporary folder."""
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    env = dict(os.environ, TMPDIR=str(tmp))
    proc = subprocess.Popen(
        [str(PHONGSCENE), *args],
        env=env,
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + WAIT_SECONDS
    while time.monotonic() < deadline and proc.poll() is None:
        povray = [c for c in _children(proc.pid) if _command(c) == "povray"]
        if povray and list(tmp.glob("phongscene-povray-*")):
            return proc, povray[0], tmp
        time.sleep(0.01)
    proc.kill()
    out, err = proc.communicate()
    pytest.fail(f"POV-Ray never started (exit {proc.returncode}): {err}")


def _finish(proc: subprocess.Popen) -> tuple[int, str]:
    try:
        _, err = proc.communicate(timeout=WAIT_SECONDS)
    except subprocess.TimeoutExpired:
        proc.kill()
        pytest.fail("phongscene did not exit after the signal")
    return proc.returncode, err


@pytest.mark.subprocess
@pytest.mark.povray
@pytest.mark.parametrize(
    "command, signum",
    [("render", signal.SIGTERM), ("render", signal.SIGHUP), ("diff", signal.SIGTERM)],
    ids=["render-SIGTERM", "render-SIGHUP", "diff-SIGTERM"],
)
def test_a_terminating_signal_kills_povray_and_removes_its_folder(tmp_path, command, signum):
    if command == "render":
        args = ["render", str(SCENE), "-o", str(tmp_path / "out.exr"), "--backend", "povray", "--width", BUSY_WIDTH]
    else:
        args = ["diff", str(SCENE), "-o", str(tmp_path / "report"), "--width", BUSY_WIDTH]
    proc, povray, tmp = _start(tmp_path, args)
    proc.send_signal(signum)
    rc, err = _finish(proc)
    assert rc == 128 + signum, err
    assert f"terminated by {signal.Signals(signum).name}" in err and "Traceback" not in err
    assert not _alive(povray), "POV-Ray still runs after phongscene exited"
    assert list(tmp.iterdir()) == [], "the phongscene-povray-* folder was left behind"
    assert not (tmp_path / "out.exr").exists()


@pytest.mark.subprocess
@pytest.mark.povray
@pytest.mark.parametrize("command", ["render", "diff"])
def test_timeout_abandons_a_stopped_povray_with_exit_3(tmp_path, command):
    if command == "render":
        args = ["render", str(SCENE), "-o", str(tmp_path / "out.exr"), "--backend", "povray", "--width", BUSY_WIDTH]
    else:
        args = ["diff", str(SCENE), "-o", str(tmp_path / "report"), "--width", BUSY_WIDTH]
    proc, povray, tmp = _start(tmp_path, [*args, "--timeout", "2"])
    os.kill(povray, signal.SIGSTOP)  # a stopped POV-Ray never exits by itself
    try:
        rc, err = _finish(proc)
    finally:
        if _alive(povray):
            os.kill(povray, signal.SIGKILL)
    assert rc == EXIT_BACKEND, err
    assert "error: POV-Ray timed out after 2 s" in err and "Traceback" not in err
    assert not _alive(povray)
    # The SDL is kept for inspection, and the message says where.
    kept = [line.split("kept:", 1)[1].strip() for line in err.splitlines() if "kept:" in line]
    assert kept and Path(kept[0]).is_file()


@pytest.mark.subprocess
def test_timeout_is_for_the_povray_backend_only(tmp_path):
    r = subprocess.run(
        [str(PHONGSCENE), "render", str(SCENE), "-o", str(tmp_path / "x.png"), "--timeout", "5"],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 2 and "--timeout applies to --backend povray only" in r.stderr
    r = subprocess.run(
        [str(PHONGSCENE), "diff", str(SCENE), "-o", str(tmp_path / "r"), "--timeout", "0"],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 2 and "expected a number of seconds > 0" in r.stderr


# Tells the test (one byte on the pipe whose fd is argv[2]) when USD's Python package pxr starts to import, then runs
# the CLI; the test sends SIGINT then, which lands while USD's C++ modules load (~0.1-0.3 s).
_SIGNAL_ME_DURING_USD_IMPORT = textwrap.dedent(
    """
    import importlib.abc, os, sys

    class Announce(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path=None, target=None):
            if name == "pxr.Tf":
                os.write(int(sys.argv[2]), b"!")
            return None

    sys.meta_path.insert(0, Announce())
    from phongscene.cli import main
    sys.exit(main(["info", sys.argv[1]]))
    """
)


def _interrupted(script: str, delay: float, signum: int = signal.SIGINT) -> tuple[subprocess.Popen, str, str]:
    """Runs ``script`` (one of the _SIGNAL_ME_... programs), sends ``signum`` ``delay`` s after it
    announces its import, and returns the process and its output."""
    read, write = os.pipe()
    proc = subprocess.Popen(
        [sys.executable, "-c", script, str(SCENE), str(write)],
        pass_fds=(write,),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    os.close(write)
    assert os.read(read, 1) == b"!"
    os.close(read)
    time.sleep(delay)
    proc.send_signal(signum)
    out, err = proc.communicate(timeout=WAIT_SECONDS)
    return proc, out, err


# Delays after pxr starts to import, all inside its ~0.1-0.3 s: which of them hit USD's swallowing
# code varies from run to run (without the fix, 3 of these 6 failed in each of two runs), and a
# longer one risks the command finishing before the signal.
@pytest.mark.subprocess
@pytest.mark.parametrize("delay", [0.0, 0.01, 0.02, 0.04, 0.06, 0.08])
def test_ctrl_c_while_usd_imports_exits_130_without_a_traceback(delay):
    proc, out, err = _interrupted(_SIGNAL_ME_DURING_USD_IMPORT, delay)
    # Before: USD's import machinery caught the KeyboardInterrupt ("Error occurred postprocessing
    # module"), finished half-initialised, and the command ran on to exit 0.
    assert proc.returncode == EXIT_INTERRUPTED, (proc.returncode, err)
    assert "interrupted" in err and "Traceback" not in err and "Error occurred" not in err
    assert "file:" not in out  # the command did not run on after the Ctrl-C


# SIGTERM and SIGHUP there too: their handler's Terminated was swallowed the same way (a signal
# sweep, benchmarks/signal_sweep.py 300 7: 15 runs exited 0 with USD's "already registered" lines).
@pytest.mark.subprocess
@pytest.mark.parametrize("delay", [0.0, 0.02, 0.06])
@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGHUP])
def test_sigterm_or_sighup_while_usd_imports_exits_with_its_status(delay, signum):
    proc, out, err = _interrupted(_SIGNAL_ME_DURING_USD_IMPORT, delay, signum)
    assert proc.returncode == 128 + signum, (proc.returncode, err)
    assert err.strip() == f"terminated by {signal.Signals(signum).name}", err
    assert "file:" not in out


# As above, but the signal comes when numpy starts to import: the first heavy import, which used to
# happen while `from phongscene.cli import main` ran, before main() could turn Ctrl-C into exit 130.
_SIGNAL_ME_DURING_NUMPY_IMPORT = _SIGNAL_ME_DURING_USD_IMPORT.replace('name == "pxr.Tf"', 'name == "numpy"')


@pytest.mark.subprocess
@pytest.mark.parametrize("delay", [0.0, 0.02, 0.05])
def test_ctrl_c_at_the_first_heavy_import_exits_130_without_a_traceback(delay):
    proc, _, err = _interrupted(_SIGNAL_ME_DURING_NUMPY_IMPORT, delay)
    assert proc.returncode == EXIT_INTERRUPTED, (proc.returncode, err)
    assert "Traceback" not in err


def test_preimport_finishes_the_import_then_raises_the_deferred_ctrl_c(tmp_path, monkeypatch):
    from phongscene.cli.process import preimport

    (tmp_path / "probe_ctrl_c.py").write_text(
        "import os, signal\nos.kill(os.getpid(), signal.SIGINT)\nx = sum(range(1000))\nFINISHED = True\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(KeyboardInterrupt):
        preimport(["probe_ctrl_c"])
    assert sys.modules["probe_ctrl_c"].FINISHED  # not interrupted half-way
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler  # the handler is back


def test_preimport_holds_sigterm_back_too_then_calls_its_handler(tmp_path, monkeypatch):
    from phongscene.cli.process import Terminated, _on_terminating_signal, preimport

    (tmp_path / "probe_sigterm.py").write_text(
        "import os, signal\nos.kill(os.getpid(), signal.SIGTERM)\nx = sum(range(1000))\nFINISHED = True\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    hangup = signal.getsignal(signal.SIGHUP)
    previous = signal.signal(signal.SIGTERM, _on_terminating_signal)
    try:
        with pytest.raises(Terminated):
            preimport(["probe_sigterm"])
        assert sys.modules["probe_sigterm"].FINISHED  # not interrupted half-way
    finally:
        signal.signal(signal.SIGTERM, previous)
        signal.signal(signal.SIGHUP, hangup)  # _on_terminating_signal ignores both once called


def test_a_termination_python_would_drop_is_delivered_again():
    # A signal handled while Python runs a __del__ or a weakref callback raises Terminated where it
    # cannot propagate (Python prints "Exception ignored" and goes on, the handlers already
    # ignoring the signals): the CI saw a SIGTERM to a Dask frame render land in WeakSet._remove
    # and the render run to its end with status 0. It must come back at the next bytecode.
    from phongscene.cli.process import (
        REDELIVERY_DELAY_S,
        Terminated,
        _on_terminating_signal,
        install_signal_handlers,
        restore_signal_handlers,
    )

    class SignalledWhileCollected:
        def __del__(self):
            _on_terminating_signal(signal.SIGTERM, None)  # as if SIGTERM arrived here

    previous = install_signal_handlers()
    try:
        deadline = time.monotonic() + 10 * REDELIVERY_DELAY_S + 5.0  # (a loaded machine)
        with pytest.raises(Terminated) as raised:
            SignalledWhileCollected()  # collected at once: its __del__'s Terminated is unraisable
            while time.monotonic() < deadline:  # bytecodes at which the signal is acted on
                pass
        assert raised.value.signum == signal.SIGTERM
    finally:
        restore_signal_handlers(previous)
    assert signal.getsignal(signal.SIGTERM) is previous[signal.SIGTERM]
    assert sys.unraisablehook is not None and "_deliver_again" not in repr(sys.unraisablehook)


# -- the `phongscene` command (cli/launcher.c) ------------------------------------------------------

HELD = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
# Sends within this long of the command's first instruction: the interpreter's start-up and the
# console module's import take ~30-60 ms here, where a Python console script died by the
# signal's default action (exit -N: 59 of 60 such sends, measured).
STARTUP_WINDOW_S = 0.06
STARTUP_SENDS = 12


def _blocked(pid: int) -> set[int]:
    """The signals ``pid`` holds back (its SigBlk mask), empty once it has gone."""
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return set()
    mask = int(next(line.split()[1] for line in status.splitlines() if line.startswith("SigBlk:")), 16)
    return {s for s in HELD if mask & (1 << (s - 1))}


@pytest.mark.subprocess
def test_a_signal_while_the_interpreter_starts_gets_the_documented_status(tmp_path):
    import random

    rng = random.Random(27)  # fixed: the same instants in every run
    statuses = {signal.SIGINT: (EXIT_INTERRUPTED, "interrupted")}
    statuses |= {s: (128 + s, f"terminated by {signal.Signals(s).name}") for s in (signal.SIGTERM, signal.SIGHUP)}
    signalled = 0
    for k in range(STARTUP_SENDS):
        signum = HELD[k % 3]
        proc = subprocess.Popen(
            [str(PHONGSCENE), "validate", str(SCENE)], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True
        )
        # From the command's first instruction (it holds the signals back; measured through
        # /proc, not guessed with a sleep), not from the fork: before main, only the dynamic
        # loader runs, and a signal there has the default action in any program.
        deadline = time.monotonic() + WAIT_SECONDS
        while _blocked(proc.pid) != set(HELD) and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.0002)
        time.sleep(rng.uniform(0.0, STARTUP_WINDOW_S))
        proc.send_signal(signum)
        _, err = proc.communicate(timeout=WAIT_SECONDS)
        code, line = statuses[signum]
        if proc.returncode != 0:  # 0: the command finished before the signal came
            assert (proc.returncode, err.strip()) == (code, line), (k, signum, proc.returncode, err)
            signalled += 1
    assert signalled >= STARTUP_SENDS // 2  # the sends fell inside the start-up, as meant


@pytest.mark.subprocess
@pytest.mark.parametrize("when", ["before", "after"])
def test_a_ctrl_c_outside_cli_mains_handling_is_interrupted_not_a_traceback(when):
    # The process's main (phongscene/console.py) lets SIGINT be KeyboardInterrupt again just
    # before cli.main, whose first lines (an import, the handlers) precede its own `except
    # KeyboardInterrupt`: a Ctrl-C there (timing the start-up sweep above met once under load),
    # or one escaping cli.main in any other way, exits 130 with one line.
    raise_it = "raise KeyboardInterrupt" if when == "before" else "import os; os.kill(os.getpid(), 2); return 0"
    code = textwrap.dedent(
        f"""
        import phongscene.cli
        def cli_main():
            {raise_it}
        phongscene.cli.main = cli_main
        from phongscene.console import main
        main()
        """
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=WAIT_SECONDS)
    assert (done.returncode, done.stderr.strip()) == (EXIT_INTERRUPTED, "interrupted"), done.stderr


@pytest.mark.subprocess
def test_the_command_passes_its_arguments_and_status_through(tmp_path):
    ok = subprocess.run([str(PHONGSCENE), "validate", str(SCENE)], capture_output=True, text=True)
    assert ok.returncode == 0, ok.stderr
    bad = subprocess.run(
        [str(PHONGSCENE), "validate", str(tmp_path / "no such file.usda")], capture_output=True, text=True
    )
    assert bad.returncode == 2 and bad.stderr.startswith("error: ") and "no such file.usda" in bad.stderr
    usage = subprocess.run([str(PHONGSCENE), "--nonsense"], capture_output=True, text=True)
    assert usage.returncode == 2 and usage.stderr.startswith("usage: phongscene")
    # The command starts the interpreter of its own environment (not whatever python3 is first
    # on PATH), with the signals it held back let in again for what phongscene starts.
    probe = subprocess.run(
        [str(PHONGSCENE), "--version"], capture_output=True, text=True, env=dict(os.environ, PATH="/nonexistent")
    )
    assert probe.returncode == 0 and probe.stdout.strip()


def test_held_signals_acts_on_the_first_signal_once_the_block_is_done(tmp_path):
    from phongscene.cli.process import Terminated, install_signal_handlers
    from phongscene.held_signals import held_signals

    previous = install_signal_handlers()
    try:
        steps = []
        with pytest.raises(Terminated) as raised:
            with held_signals():
                signal.raise_signal(signal.SIGHUP)
                steps.append("after the signal")  # the block is not cut short
                signal.raise_signal(signal.SIGTERM)
        assert steps == ["after the signal"] and raised.value.signum == signal.SIGHUP
        with pytest.raises(KeyboardInterrupt):
            with held_signals():
                signal.raise_signal(signal.SIGINT)
        with held_signals():
            pass  # nothing came: nothing raised
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)

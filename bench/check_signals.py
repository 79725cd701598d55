"""Real signals to running `bsrflow` commands: do they end with one line and the right exit code?

    python bench/check_signals.py [--commands energy verify] [--delays 0.3 0.8 1.5 2.5 4 6]

For each command, delay and signal (SIGTERM, SIGINT) it starts ``python -m bsrflow COMMAND`` in a
session of its own, sends the signal after the delay, and prints the exit code (143 / 130
expected), the seconds from the signal to the end, and OK when stderr is exactly one line.  A
delay shorter than ``--handler-after`` (default 1 s) may reach Python while it imports numba,
before bsrflow's handler is installed (Python's defaults: -15, or a KeyboardInterrupt traceback;
about 0.5 s on a quiet machine, more under load): not counted, shown as such.  Takes about a
minute and a half; writes nothing; exit 1 if a counted case is not OK.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

from _args import Parser, float_in


# the commands that run with no arguments and write no file (the others need a file, or write one)
_COMMANDS = ("energy", "verify", "stability")


def main() -> int:
    ap = Parser(description=__doc__.splitlines()[0])
    ap.add_argument("--commands", nargs="+", default=["energy", "verify"], choices=_COMMANDS,
                    help="bsrflow commands to signal, run without arguments (default energy verify)")
    ap.add_argument("--delays", nargs="+", type=float_in(0.0, 600.0), default=[0.3, 0.8, 1.5, 2.5, 4.0, 6.0],
                    metavar="S", help="seconds from the start to the signal (default 0.3 0.8 1.5 2.5 4 6)")
    ap.add_argument("--handler-after", type=float_in(0.0, 600.0), default=1.0, metavar="S",
                    help="count only delays of at least S seconds (default 1)")
    args = ap.parse_args()
    ok = total = 0
    for command in args.commands:
        for delay in args.delays:
            for sig in (signal.SIGTERM, signal.SIGINT):
                p = subprocess.Popen([sys.executable, "-m", "bsrflow", command], start_new_session=True,
                                     stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
                time.sleep(delay)
                t0 = time.perf_counter()
                os.kill(p.pid, sig)
                try:
                    _, err = p.communicate(timeout=120)
                except subprocess.TimeoutExpired:
                    os.killpg(p.pid, signal.SIGKILL)
                    _, err = p.communicate()
                    err = "(still running 120 s after the signal; killed)\n" + err
                lines = err.strip().splitlines()
                good = p.returncode == 128 + int(sig) and len(lines) == 1
                counted = delay >= args.handler_after
                ok += good and counted
                total += counted
                tag = ("OK" if good else "BAD") + ("" if counted else " (not counted: may be before the handler)")
                print(f"{command:8s} {delay:4.1f} s {sig.name:7s} exit {p.returncode:4d} after "
                      f"{time.perf_counter() - t0:4.1f} s  {tag}: {lines[-1] if lines else ''}", flush=True)
    print(f"{ok} of {total} OK at delays of {args.handler_after:g} s or more")
    return 0 if ok == total else 1


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env python3
"""The launcher's one progress line for a coupled run (started by launch/coupled-inner.sh).

    /usr/bin/python3 launch/progress.py OUTPUT_DIR --pid FLUID_PID [--label TEXT] [--quiet]
                                        [--from-bytes FLUID SOLID] [--solid-pid PID]

Follows OUTPUT_DIR/fluid.log and OUTPUT_DIR/solid.log while the fluid (FLUID_PID) runs. Both
servers write a "progress" line every second (common/log/logger.hpp); they are shown merged
as one line:

    run 2 of 5  free  step 9000/30000 (30 %)  t = 31.2 us  4.1 MLUPS  fluid compute 58 % wait 41 %
    solid compute 37 % wait 61 %  ETA 1 min 35 s

(one line; the label is --label or the environment's COSIM_RUN_LABEL, set by the sweeps and
studies). On a terminal it is rewritten in place; otherwise one line every
COSIM_PROGRESS_EVERY_S seconds (default 10). The fluid's other lines (its header, "sheet
released at step N", warnings, its closing summary) are shown as they come; its monitor rows
("step N  t = ...") stay in fluid.log. With --quiet (the servers print no progress) only the
fluid's closing summary and any line after it are shown. With COSIM_PROGRESS_TTY=1 (the
sweeps, whose launcher output goes to a log file) the progress line also goes to the
controlling terminal, /dev/tty, when there is one.
"""
import argparse
import os
import re
import signal
import sys
import time

PROGRESS = re.compile(
    r"^(fluid|solid): progress step (\d+)/(\d+)\s+phase (\S+)\s+t = (\S+) us\s+(\S+) (MLUPS|LB steps/s)\s+"
    r"compute (\d+) %\s+wait (\d+) %\s+ETA (.+?)(\s+iteration \d+)?$")
MONITOR_ROW = re.compile(r"^step \d+  t = ")
SUMMARY_START = "fluid: coupled run done"


class Follower:
    """New complete lines of a file that another process appends to."""

    def __init__(self, path, start=0):
        self.path, self.pos, self.partial = path, start, ""

    def lines(self):
        try:
            with open(self.path, "r", errors="replace") as f:
                f.seek(self.pos)
                data = f.read()
                self.pos = f.tell()
        except FileNotFoundError:
            return []
        data = self.partial + data
        parts = data.split("\n")
        self.partial = parts.pop()
        return parts

    def rest(self):
        out = self.lines()
        if self.partial:
            out.append(self.partial)
            self.partial = ""
        return out


def alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def compose(fluid, solid, label):
    """The one line from the latest progress of each side (either may be missing); each is
    PROGRESS's groups: side, step, total, phase, t, rate, rate unit, compute, wait, ETA."""
    lead = fluid or solid
    step, total = int(lead[1]), int(lead[2])
    parts = [label] if label else []
    parts.append(lead[3])
    parts.append(f"step {step}/{total} ({100.0 * step / total if total else 0.0:.0f} %)")
    parts.append(f"t = {lead[4]} us")
    if fluid:
        parts.append(f"{fluid[5]} MLUPS")
        parts.append(f"fluid compute {fluid[7]} % wait {fluid[8]} %")
    if solid:
        parts.append(f"solid compute {solid[7]} % wait {solid[8]} %")
    parts.append(f"ETA {lead[9]}")
    return "  ".join(parts)


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    ap.add_argument("output", help="the run's output folder (fluid.log, solid.log)")
    ap.add_argument("--pid", type=int, required=True, help="the fluid's process id: follow while it runs")
    ap.add_argument("--solid-pid", type=int, default=0,
                    help="the solid's process id: its last lines are read once it has ended too")
    ap.add_argument("--label", default=os.environ.get("COSIM_RUN_LABEL", ""),
                    help="shown first, e.g. 'run 2 of 5' (default: $COSIM_RUN_LABEL)")
    ap.add_argument("--quiet", action="store_true", help="only the fluid's closing summary")
    ap.add_argument("--from-bytes", type=int, nargs=2, default=[0, 0], metavar=("FLUID", "SOLID"),
                    help="where this run's lines start in fluid.log and solid.log (a restart appends)")
    a = ap.parse_args(argv[1:])
    # Ctrl-C on the terminal is the launcher's to handle (it stops both servers, whose last
    # lines this still shows); this ends when the fluid does.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    tty = sys.stdout.isatty()
    try:
        every = float(os.environ.get("COSIM_PROGRESS_EVERY_S", "10"))
    except ValueError:
        every = 10.0
    every = 0.5 if tty else max(every, 0.05)
    fluid_log = Follower(os.path.join(a.output, "fluid.log"), a.from_bytes[0])
    solid_log = Follower(os.path.join(a.output, "solid.log"), a.from_bytes[1])
    latest = {"fluid": None, "solid": None}
    state = {"shown": False, "last": 0.0, "fresh": False, "summary": False}

    def clear():
        if state["shown"]:
            sys.stdout.write("\r" + " " * 150 + "\r")
            state["shown"] = False

    def take(lines, side):
        for line in lines:
            m = PROGRESS.match(line)
            if m:
                latest[m.group(1)] = m.groups()
                state["fresh"] = True
                continue
            if side != "fluid":
                continue
            if line.startswith(SUMMARY_START):
                state["summary"] = True
            if MONITOR_ROW.match(line) or (a.quiet and not state["summary"]) or not line.strip():
                continue
            clear()
            print(line, flush=True)

    def show(force=False):
        if a.quiet or not state["fresh"] or not (latest["fluid"] or latest["solid"]):
            return
        now = time.monotonic()
        if not force and now - state["last"] < every:
            return
        state["last"], state["fresh"] = now, False
        text = compose(latest["fluid"], latest["solid"], a.label)
        if tty:
            sys.stdout.write("\r" + text[:200] + "    ")
            state["shown"] = True
        else:
            sys.stdout.write(text + "\n")
        sys.stdout.flush()

    try:  # the sweeps' terminal (their launcher's stdout is a log file)
        term = open("/dev/tty", "w") if os.environ.get("COSIM_PROGRESS_TTY") == "1" and not tty else None
    except OSError:
        term = None

    def show_term():
        if term and (latest["fluid"] or latest["solid"]):
            term.write("\r" + compose(latest["fluid"], latest["solid"], a.label)[:200] + "    ")
            term.flush()

    last_term = 0.0
    while alive(a.pid):
        take(fluid_log.lines(), "fluid")
        take(solid_log.lines(), "solid")
        show()
        if term and time.monotonic() - last_term >= 0.5:
            last_term = time.monotonic()
            show_term()
        time.sleep(0.2)
    # The solid writes its last line as it ends, maybe after the fluid: wait for it (the
    # launcher stops a solid that outlives its grace), then both sides' last lines count.
    while a.solid_pid and alive(a.solid_pid):
        time.sleep(0.05)
    fluid_rest = fluid_log.rest()
    for line in fluid_rest:
        m = PROGRESS.match(line)
        if m:
            latest[m.group(1)] = m.groups()
            state["fresh"] = True
    take(solid_log.rest(), "solid")
    show(force=not tty)  # a log's last word on the progress
    clear()
    if term:
        term.write("\r" + " " * 150 + "\r")
        term.close()
    take(fluid_rest, "fluid")
    sys.stdout.flush()
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv))
    except KeyboardInterrupt:
        sys.exit(130)

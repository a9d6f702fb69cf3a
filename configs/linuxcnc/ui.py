#!/usr/bin/python3
"""Headless user interface of acc's LinuxCNC configuration (acc.ini [DISPLAY] DISPLAY).

Invoked as root: the servo thread SCHED_FIFO, acc and the process reniced (realtime_priority).
Once acc's heartbeat toggles, the watchdog is armed (the operator's reset before the cycle).
Then estop reset, machine on, home all, MODE_AUTO, feed override 150 % (acc's range, see
docs/linuxcnc.md), open [DISPLAY] OPEN_FILE, run it (resuming the program's own M0/M1 pauses after
0.5 s, the operator's cycle start), wait until the interpreter is idle,
exit (LinuxCNC then shuts down). Writes ui.log beside the INI: one line per step, with
time.monotonic() stamps, and `cycle_s` (program start to idle).

M52 for acc: the HAL component `acc-ui` of this script has one pin, `acc-ui.adaptive-enabled`
(bit out), joined to acc.hal's signal `acc-adaptive` (=> acc.adaptive-enabled). After every
stat poll it is `stat().adaptive_feed_enabled`: during a program, the AF bit of the move
the motion controller executes (LinuxCNC's enables_queued), so `M52 P0` / `M52 P1` reach acc
when the motion reaches them, not when the interpreter reads them (docs/linuxcnc.md).

Environment: ACC_FAULT=KIND@N[+S]: the fault test. S seconds (default 0) after
acc-process.force first reaches N newtons, set acc-process.fault (the machine log's `fault`
column marks the moment) and:
  kill-acc       SIGKILL the HAL component `acc`; abort the program 2 s later
  stop-acc       SIGSTOP acc, SIGCONT 2 s later, re-arm the watchdog 0.5 s after that
                 (watchdog.enable-in 0, then 1: the operator's reset); the program goes on
  kill-process   SIGKILL the simulated process `acc-process`: acc.spindle-power and
                 acc.sample-seq keep their last values while the spindle turns
  feed-override  the operator's feed override to 30 % (feedrate(0.3))
  pause          pause the program (AUTO_PAUSE), resume it 2 s later
  estop          estop: the program ends there
  m52-off        none of ours: the program's own `M52 P0`. The marker is set while the
                 adaptive feed is off (M52 P0 in force) and cleared when it is on again
  abort-restart  abort the program (the operator's abort), retract Z 10 mm by MDI, 1 s
                 later run it again from its start (M52 P1 by MDI, feed override 150 %,
                 AUTO_RUN as at the start); the marker is cleared when the second run starts
  tool-change    none of ours: the program's own `M6`. The marker is set when the tool in
                 the spindle changes
ACC_KILL_AT_FORCE_N=N is kill-acc@N. ACC_PROGRAM_TIMEOUT_S: the longest program run, s
(default 600); after it the program is aborted and the script exits with status 3.
"""
import os
import signal
import subprocess
import sys
import time

import hal
import linuxcnc

ini_path = sys.argv[sys.argv.index("-ini") + 1] if "-ini" in sys.argv else "acc.ini"
here = os.path.dirname(os.path.abspath(ini_path))
log = open(os.path.join(here, "ui.log"), "w", buffering=1)


def say(what):
    log.write("%.4f %s\n" % (time.monotonic(), what))


def wait(cond, timeout, what):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        poll()
        if cond():
            return
        time.sleep(0.02)
    say("TIMEOUT " + what)
    sys.exit(3)


def getp(pin):
    """A pin's or signal's value (hal.get_value: no halcmd process per read)."""
    try:
        return hal.get_value(pin)
    except Exception:  # not there (yet, or any more)
        return None


def comp_pid(name):
    out = subprocess.run(["halcmd", "-s", "show", "comp", name], capture_output=True, text=True)
    for line in out.stdout.splitlines():
        f = line.split()
        # ID  Type  Name  PID  State
        if len(f) >= 4 and f[2] == name and f[3].isdigit():
            return int(f[3])
    return None


ui = hal.component("acc-ui")
ui.newpin("adaptive-enabled", hal.HAL_BIT, hal.HAL_OUT)
ui.ready()
# acc.hal made the signal (acc.adaptive-enabled reads it): no M52 P1 seen until now.
hal.connect("acc-ui.adaptive-enabled", "acc-adaptive")


def poll():
    """stat() polled, and M52 published to acc."""
    s.poll()
    ui["adaptive-enabled"] = bool(s.adaptive_feed_enabled)


inifile = linuxcnc.ini(ini_path)
program = inifile.find("DISPLAY", "OPEN_FILE")
c = linuxcnc.command()
s = linuxcnc.stat()
e = linuxcnc.error_channel()
fault = os.environ.get("ACC_FAULT") or ""
if not fault and os.environ.get("ACC_KILL_AT_FORCE_N"):
    fault = "kill-acc@" + os.environ["ACC_KILL_AT_FORCE_N"]
fault_kind, _, fault_at = fault.partition("@")
fault_at, _, fault_delay = fault_at.partition("+")
fault_at = float(fault_at) if fault else None
fault_delay = float(fault_delay or "0")
reached = None


def setp(pin, value):
    try:
        hal.set_p(pin, str(value))
    except Exception:
        subprocess.run(["halcmd", "setp", pin, str(value)], capture_output=True)


def signal_comp(name, sig, what):
    pid = comp_pid(name)
    if pid:
        os.kill(pid, sig)
        say("%s %s pid %d" % (what, name, pid))
    else:
        say("no pid of %s" % name)


def mark(on):
    """The machine log's fault marker (acc-process.fault)."""
    setp("acc-process.fault", 1 if on else 0)


def run_program(what):
    """M52 P1 by MDI, MODE_AUTO, feed override 150 %, the program run from its start."""
    # M52 P1 once more by MDI: the startup code's runs while the machine is still in
    # estop, and its motion message does not survive the machine coming on.
    c.mode(linuxcnc.MODE_MDI)
    c.wait_complete()
    c.mdi("M52 P1")
    c.wait_complete()
    say("M52 P1")
    c.mode(linuxcnc.MODE_AUTO)
    c.wait_complete()
    c.feedrate(1.5)
    c.program_open(program)
    c.wait_complete()
    c.auto(linuxcnc.AUTO_RUN, 0)
    say("%s %s" % (what, program))
    return time.monotonic()


def realtime_priority():
    """Invoked as root, LinuxCNC's realtime runs as `nobody` without realtime scheduling:
    on a loaded host its servo thread then stalls for 0.1 s and more, and the watchdog,
    counting the stalled periods at once when the thread runs again, trips on an alive acc.
    The servo thread gets SCHED_FIFO (as a setuid rtapi_app gives it on an installed
    machine), acc and the process a higher share of the CPU."""
    if os.geteuid() != 0:
        return
    for name, cmd in (
        ("rtapi_app", ["chrt", "-a", "-f", "-p", "70"]),
        ("acc", ["renice", "-n", "-10", "-p"]),
        ("acc-process", ["renice", "-n", "-10", "-p"]),
    ):
        if name == "rtapi_app":
            out = subprocess.run(["pidof", name], capture_output=True, text=True).stdout.split()
            pid = int(out[0]) if out else None
        else:
            pid = comp_pid(name)
        if pid is None:
            say("priority: no pid of %s" % name)
            continue
        r = subprocess.run(cmd + [str(pid)], capture_output=True, text=True)
        failed = "" if r.returncode == 0 else " failed: " + r.stderr.strip()
        say("priority: %s %d%s" % (" ".join(cmd), pid, failed))


def arm_watchdog():
    """The operator's reset before the cycle: once acc's heartbeat toggles (acc is alive),
    the watchdog is re-armed (enable-in 0, then 1), so that a trip while LinuxCNC started
    (threads running before acc's first beat, or before the priority above) does not hold
    the program's feed. A trip from now on holds it as designed."""
    seen = []
    t0 = time.monotonic()
    while len(seen) < 3 and time.monotonic() - t0 < 5.0:
        b = getp("acc.heartbeat-bit")
        if not seen or b != seen[-1]:
            seen.append(b)
        time.sleep(0.005)
    if len(seen) < 3:
        say("watchdog: acc's heartbeat did not toggle in 5 s; not re-armed")
        return
    was = getp("watchdog.ok-out")
    setp("watchdog.enable-in", 0)
    time.sleep(0.02)
    setp("watchdog.enable-in", 1)
    time.sleep(0.02)
    say("watchdog armed (ok-out was %s, now %s)" % (was, getp("watchdog.ok-out")))


realtime_priority()
arm_watchdog()
c.state(linuxcnc.STATE_ESTOP_RESET)
c.state(linuxcnc.STATE_ON)
wait(lambda: s.task_state == linuxcnc.STATE_ON, 10, "machine on")
say("machine on")
c.mode(linuxcnc.MODE_MANUAL)
c.wait_complete()
c.home(-1)
wait(lambda: all(s.homed[i] for i in range(3)), 20, "homed")
say("homed")
start = run_program("run")
first_start = start
killed = None
fired = None
# The fault's later steps: (seconds after the fault, what).
steps = []
# The feed held (motion.feed-inhibit: the watchdog tripped, or acc's feed hold) for
# HELD_S without a kill of ours: abort, the program does not complete.
HELD_S = 5.0
held_since = None
next_check = 0.0
# tool-change: the tool in the spindle when the force was reached.
tool_was = None
# The longest program run, s (acc linuxcnc: its --timeout-s less the start and the stop).
PROGRAM_TIMEOUT_S = float(os.environ.get("ACC_PROGRAM_TIMEOUT_S") or "600")
# Since when the program's own M0/M1 pauses it.
program_paused = None
while True:
    poll()
    msg = e.poll()
    if msg:
        # Errors stop the program; the rest is the program's or the operator's text.
        if msg[0] in (linuxcnc.NML_ERROR, linuxcnc.OPERATOR_ERROR):
            say("error %s" % (msg[1],))
        else:
            say("message %s" % (msg[1],))
    if time.monotonic() - start > 0.5 and s.interp_state == linuxcnc.INTERP_IDLE and not steps:
        break
    if fault_at is not None and fired is None:
        try:
            force = float(getp("acc-process.force") or 0.0)
        except (TypeError, ValueError):
            force = 0.0
        if reached is None and force >= fault_at:
            reached = time.monotonic()
            say("force %.1f N reached: the fault in %.1f s" % (force, fault_delay))
        if reached is not None and time.monotonic() - reached >= fault_delay:
            if fault_kind == "m52-off":
                if not s.adaptive_feed_enabled:
                    mark(True)
                    fired = time.monotonic()
                    say("fault m52-off: adaptive feed off (M52 P0) at force %.1f N" % force)
            elif fault_kind == "tool-change":
                if tool_was is None:
                    tool_was = s.tool_in_spindle
                elif s.tool_in_spindle != tool_was:
                    mark(True)
                    fired = time.monotonic()
                    say("fault tool-change: tool %d -> %d" % (tool_was, s.tool_in_spindle))
            else:
                mark(True)
                fired = time.monotonic()
                say("fault %s at force %.1f N" % (fault_kind, force))
            if fired is None:
                pass
            elif fault_kind == "kill-acc":
                signal_comp("acc", signal.SIGKILL, "SIGKILL")
                killed = fired
            elif fault_kind == "stop-acc":
                signal_comp("acc", signal.SIGSTOP, "SIGSTOP")
                steps = [(2.0, "cont"), (2.5, "rearm")]
            elif fault_kind == "kill-process":
                time.sleep(0.02)  # the process logs the marker first
                signal_comp("acc-process", signal.SIGKILL, "SIGKILL")
            elif fault_kind == "feed-override":
                c.feedrate(0.3)
                say("feed override 30 %")
            elif fault_kind == "pause":
                c.auto(linuxcnc.AUTO_PAUSE)
                say("paused")
                steps = [(2.0, "resume")]
            elif fault_kind == "estop":
                c.state(linuxcnc.STATE_ESTOP)
                say("estop")
            elif fault_kind == "abort-restart":
                c.abort()
                c.wait_complete()
                # The operator takes the tool out of the cut along its axis before the
                # restart (the program's first rapid would drag it through the stock).
                c.mode(linuxcnc.MODE_MDI)
                c.wait_complete()
                c.mdi("G91 G0 Z10")
                c.wait_complete()
                c.mdi("G90")
                c.wait_complete()
                say("operator abort, Z retracted 10 mm; the program runs again in 1 s")
                steps = [(1.0, "restart")]
            elif fault_kind == "m52-off":
                steps = [(0.0, "m52-on")]
            elif fault_kind == "tool-change":
                pass
            else:
                say("unknown fault %s" % fault_kind)
    if steps and steps[0][1] == "m52-on":
        if s.adaptive_feed_enabled:
            steps.pop(0)
            mark(False)
            say("adaptive feed on again (M52 P1)")
        elif s.interp_state == linuxcnc.INTERP_IDLE:
            steps.pop(0)
    elif steps and time.monotonic() - fired >= steps[0][0]:
        step = steps.pop(0)[1]
        if step == "cont":
            signal_comp("acc", signal.SIGCONT, "SIGCONT")
        elif step == "rearm":
            setp("watchdog.enable-in", 0)
            time.sleep(0.01)
            setp("watchdog.enable-in", 1)
            say("watchdog re-armed")
        elif step == "resume":
            c.auto(linuxcnc.AUTO_RESUME)
            say("resumed")
        elif step == "restart":
            start = run_program("run again")
            mark(False)
    # The program's own pause (M0, M1): the operator's cycle start 0.5 s later, as acc sim
    # --program runs on through it. Our `pause` fault resumes by its own step.
    if s.interp_state == linuxcnc.INTERP_PAUSED and not any(st[1] == "resume" for st in steps):
        program_paused = program_paused or time.monotonic()
        if time.monotonic() - program_paused > 0.5:
            c.auto(linuxcnc.AUTO_RESUME)
            say("program pause (M0/M1): resumed (the operator's cycle start)")
            program_paused = None
    else:
        program_paused = None
    now = time.monotonic()
    if killed is None and now >= next_check:
        next_check = now + 0.5
        if getp("motion.feed-inhibit"):
            held_since = held_since or now
            if now - held_since > HELD_S:
                say("feed inhibited for %.0f s (watchdog or acc's feed hold): aborting" % HELD_S)
                c.abort()
                c.wait_complete()
                say("aborted")
                c.state(linuxcnc.STATE_OFF)
                sys.exit(4)
        else:
            held_since = None
    if killed is not None and time.monotonic() - killed > 2.0:
        c.abort()
        c.wait_complete()
        say("aborted")
        break
    if time.monotonic() - first_start > PROGRAM_TIMEOUT_S:
        say("TIMEOUT program: not done after %.0f s (acc linuxcnc --timeout-s): aborted" % PROGRAM_TIMEOUT_S)
        c.abort()
        c.wait_complete()
        c.state(linuxcnc.STATE_OFF)
        sys.exit(3)
    time.sleep(0.02)
say("cycle_s %.3f" % (time.monotonic() - start))
c.state(linuxcnc.STATE_OFF)
say("done")

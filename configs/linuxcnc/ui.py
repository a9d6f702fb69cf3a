#!/usr/bin/python3
"""Headless user interface of acc's LinuxCNC configuration (acc.ini [DISPLAY] DISPLAY).

Estop reset, machine on, home all, MODE_AUTO, feed override 150 % (acc's range, see
docs/linuxcnc.md), open [DISPLAY] OPEN_FILE, run it, wait until the interpreter is idle,
exit (LinuxCNC then shuts down). Writes ui.log beside the INI: one line per step, with
time.monotonic() stamps, and `cycle_s` (program start to idle).

Environment: ACC_KILL_AT_FORCE_N=N: SIGKILL the HAL component `acc` the first time
acc-process.force reaches N newtons (the fault test), then abort the program 2 s later.
"""
import os
import signal
import subprocess
import sys
import time

import linuxcnc

ini_path = sys.argv[sys.argv.index("-ini") + 1] if "-ini" in sys.argv else "acc.ini"
here = os.path.dirname(os.path.abspath(ini_path))
log = open(os.path.join(here, "ui.log"), "w", buffering=1)


def say(what):
    log.write("%.4f %s\n" % (time.monotonic(), what))


def wait(cond, timeout, what):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        s.poll()
        if cond():
            return
        time.sleep(0.02)
    say("TIMEOUT " + what)
    sys.exit(3)


def getp(pin):
    out = subprocess.run(["halcmd", "-s", "getp", pin], capture_output=True, text=True)
    return out.stdout.strip()


def comp_pid(name):
    out = subprocess.run(["halcmd", "-s", "show", "comp", name], capture_output=True, text=True)
    for line in out.stdout.splitlines():
        f = line.split()
        # ID  Type  Name  PID  State
        if len(f) >= 4 and f[2] == name and f[3].isdigit():
            return int(f[3])
    return None


inifile = linuxcnc.ini(ini_path)
program = inifile.find("DISPLAY", "OPEN_FILE")
c = linuxcnc.command()
s = linuxcnc.stat()
e = linuxcnc.error_channel()
kill_at = os.environ.get("ACC_KILL_AT_FORCE_N")

c.state(linuxcnc.STATE_ESTOP_RESET)
c.state(linuxcnc.STATE_ON)
wait(lambda: s.task_state == linuxcnc.STATE_ON, 10, "machine on")
say("machine on")
c.mode(linuxcnc.MODE_MANUAL)
c.wait_complete()
c.home(-1)
wait(lambda: all(s.homed[i] for i in range(3)), 20, "homed")
say("homed")
# M52 P1 once more by MDI: the startup code's runs while the machine is still in estop,
# and its motion message does not survive the machine coming on.
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
start = time.monotonic()
c.auto(linuxcnc.AUTO_RUN, 0)
say("run " + program)
killed = None
# The feed held (motion.feed-inhibit: the watchdog tripped, or acc's feed hold) for
# HELD_S without a kill of ours: abort, the program does not complete.
HELD_S = 5.0
held_since = None
next_check = 0.0
while True:
    s.poll()
    msg = e.poll()
    if msg:
        say("error %s" % (msg[1],))
    if time.monotonic() - start > 0.5 and s.interp_state == linuxcnc.INTERP_IDLE:
        break
    if kill_at and killed is None:
        try:
            force = float(getp("acc-process.force") or "0")
        except ValueError:
            force = 0.0
        if force >= float(kill_at):
            pid = comp_pid("acc")
            if pid:
                os.kill(pid, signal.SIGKILL)
                killed = time.monotonic()
                say("killed acc pid %d at force %.1f N" % (pid, force))
    now = time.monotonic()
    if killed is None and now >= next_check:
        next_check = now + 0.5
        if getp("motion.feed-inhibit") == "TRUE":
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
    if time.monotonic() - start > 600:
        say("TIMEOUT program")
        c.abort()
        break
    time.sleep(0.02)
say("cycle_s %.3f" % (time.monotonic() - start))
c.state(linuxcnc.STATE_OFF)
say("done")

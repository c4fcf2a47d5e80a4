#!/usr/bin/env python3
"""ajarctl drive (keys) in a pseudo-terminal against the real ajard (run by with_ajard.sh).

Presses Up (as an escape sequence) and w, waits, then q; checks that ajarctl exits 0, showed the
velocity it set and the loop's commanded velocity, that the base moved forward and is at rest with
nothing commanded afterwards, and that the terminal is back in its cooked mode (echo, canonical).
On a daemon that does not drive yet (RobotModel max_linear_speed_m_s 0) it checks instead that the
first key's Drive is refused: exit 1 with NOT_SUPPORTED, terminal restored.
    drive_keys_test.py AJARCTL PORT
"""
import json
import os
import pty
import select
import subprocess
import sys
import termios
import time

ajarctl, port = sys.argv[1], sys.argv[2]
base = [ajarctl, "--connect", f"127.0.0.1:{port}"]


def fail(why, out=b""):
    print("FAIL:", why)
    print(out.decode(errors="replace").replace("\r", "\n"))
    sys.exit(1)


def query(*args):
    return json.loads(subprocess.run(base + ["--json", *args], check=True, capture_output=True,
                                     text=True).stdout.splitlines()[-1])


drives = query("model")["robot_model"]["max_linear_speed_m_s"] > 0
before = query("status")["status"]

pid, fd = pty.fork()
if pid == 0:
    os.execv(ajarctl, base + ["drive"])
out = b""


def pump(seconds):
    global out
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        ready, _, _ = select.select([fd], [], [], 0.05)
        if ready:
            try:
                out += os.read(fd, 4096)
            except OSError:
                return


def pump_until(text, seconds):
    end = time.monotonic() + seconds
    while text not in out and time.monotonic() < end:
        pump(0.05)
    if text not in out:
        fail(f"ajarctl drive did not show {text!r} within {seconds} s", out)


# Keys are pressed once the first status line is drawn: the terminal is raw from then on. A key
# typed before that is discarded on purpose (the raw mode is set with TCSAFLUSH: nothing typed
# while ajarctl was still starting moves the robot), so a fixed wait lost the first key on a
# loaded machine.
pump_until(b"\x1b[Kset ", 20)
for key in (b"\x1b[A", b"w"):
    os.write(fd, key)
    pump(0.5)
pump(1.0)
os.write(fd, b"q")
deadline = time.monotonic() + 10
status = None
while status is None and time.monotonic() < deadline:
    pump(0.1)
    done, status = os.waitpid(pid, os.WNOHANG)
    if done == 0:
        status = None
if status is None:
    os.kill(pid, 9)
    fail("ajarctl drive did not leave after q", out)
attrs = termios.tcgetattr(fd)  # the pty's settings as ajarctl left them
if not (attrs[3] & termios.ECHO and attrs[3] & termios.ICANON):
    fail("the terminal was not restored (echo/canonical mode off)", out)
code = os.waitstatus_to_exitcode(status)
text = out.decode(errors="replace")

if not drives:
    if code != 1 or "NOT_SUPPORTED" not in text:
        fail(f"a daemon that does not drive: want exit 1 with NOT_SUPPORTED, got exit {code}", out)
    print("PASS (the daemon does not drive yet: the refusal ends the teleop, terminal restored)")
    sys.exit(0)

if code != 0:
    fail(f"exit {code}", out)
if "set +0.060 m/s" not in text:
    fail("two steps forward were not shown as the velocity set", out)
if "moving" not in text:
    fail("the loop's commanded velocity / moving never showed", out)
deadline = time.monotonic() + 5  # leaving sent Drive 0 and Stop: the jog ramps down to rest
while True:
    after = query("status")["status"]
    resting = after["commanded_linear_m_s"] == 0 and after["commanded_angular_rad_s"] == 0
    if resting or time.monotonic() > deadline:
        break
    time.sleep(0.05)
if not resting:
    fail("still commanding a velocity 5 s after leaving", out)
moved = after["odometry_x_m"] - before["odometry_x_m"]
if not moved > 0.01:
    fail(f"the base moved {moved} m forward", out)
print(f"PASS (moved {moved:.3f} m, at rest, terminal restored)")

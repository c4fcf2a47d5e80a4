#!/usr/bin/env python3
"""The loop supervisor (dec3e66) against a starved control thread and a hung card call (root).

Usage: starve_stall.py MODE [trials] [seed]      (env TIMEOUTS="0.1,0.02", DUR=20, LOOPCPU=1)
  none       the same load without any starvation (the machine's own noise: the baseline)
  fifo       no latch expected: ajar-loop pinned to LOOPCPU; SCHED_FIFO hogs of 0.2-0.9 s pinned
             there at random instants while the base jogs back and forth and an observer
             subscribes to telemetry at 500 Hz; DUR s per trial and timeout.
  tear       the same with back-to-back short hogs (30-80 ms, 10-50 ms apart): every hog's end
             is a chance for a check that reads run_delay before the wait ends and the CPU clock
             after it (use TIMEOUTS=0.02: a latch with silent > 28 ms and ~0 excused at a hog's end)
  late       the same as fifo with hogs of 0.3-0.7 s, and the supervisor (pinned to the other CPU
             with ajard's other threads) kept off its CPU by a second SCHED_FIFO hog for the
             first 40-85 % of each: it sees the loop's wait only late (wave 12, A3; no latch
             expected since the control thread publishes its sleep).
  cfs        the same with 1-4 nice-0 spinners pinned to the loop's CPU for 0.5-3 s at a time.
  cgroup     the same with ajard (every thread) in a cgroup-v1 cpu group throttled to 1-5 ms per
             50-500 ms for 1-3 s at a time; `cgroup-loop`: only the ajar-loop thread in it.
  hang       latch expected: a FIFO hog (0.2-0.9 s) on the loop's CPU and a hung GT_* call
             (AJAR_SIM_BLOCK_FILE, the simulator's sleeping hang) at random offsets (hang before
             the hog, hog before the hang, hog ending mid-hang); one hang per trial. Prints the
             delay from the hang to the journal's latch line, minus the hog's overlap.
  spin       the same with a hang that SPINS on the CPU (spin_preload.c wraps GT_GetSts).
  rt-starve  control.realtime on (ajar-loop and the supervisor SCHED_FIFO 80, the robot's
             setting; stall_timeout_s 0.02): a SCHED_FIFO 90 hog of HOG s (default 3) on the
             loop's CPU mid-jog, an EmergencyStop 0.2 s into it. No card call hangs; the loop
             makes no cycle for HOG s. Prints whether anything latched and how far the base went
             after the EmergencyStop.
FLIP=0: the jog goes one way only (default: +-0.1 m/s, reversed every second). Unless PIN_OTHERS=0, ajard's other threads are pinned to the other CPU (the supervisor's view is
then not starved with the loop). Prints the seed, the load average, every latch's journal lines;
last line `RESULT ...`.
"""
import glob
import os
import random
import re
import struct
import subprocess
import sys
import threading
import time

from ajarwire import *

MAIN = __name__ == "__main__"  # imported (pause_kill.py): the helpers only
MODE = sys.argv[1] if MAIN else "lib"
TRIALS = int(sys.argv[2]) if MAIN and len(sys.argv) > 2 else 3
SEED = int(sys.argv[3]) if MAIN and len(sys.argv) > 3 else int(time.time())
TIMEOUTS = [float(x) for x in os.environ.get("TIMEOUTS", "0.1,0.02").split(",")]
DUR = float(os.environ.get("DUR", "20"))
LOOPCPU = int(os.environ.get("LOOPCPU", "1"))
OTHERCPU = 1 - LOOPCPU
PIN_OTHERS = os.environ.get("PIN_OTHERS", "1") == "1"
FLIP = os.environ.get("FLIP", "1") == "1"  # 0: jog one way only
rng = random.Random(SEED)
HERE = os.path.dirname(os.path.abspath(__file__))
LATCH_LINE = "loop supervisor: the control thread made no cycle"


def loadavg():
    return " ".join(open("/proc/loadavg").read().split()[:3])


def threads(pid):
    out = {}
    for d in glob.glob("/proc/%d/task/*" % pid):
        try:
            out[int(os.path.basename(d))] = open(d + "/comm").read().strip()
        except OSError:
            pass
    return out


def pin(pid):
    ts = threads(pid)
    loop = [t for t, n in ts.items() if n == "ajar-loop"]
    assert len(loop) == 1, ts
    os.sched_setaffinity(loop[0], {LOOPCPU})
    if PIN_OTHERS:
        for t in ts:
            if t != loop[0]:
                os.sched_setaffinity(t, {OTHERCPU})
    return loop[0], ts


HOG_SRC = r"""
import os, sys, time
cpu, policy, prio = int(sys.argv[1]), sys.argv[2], int(sys.argv[3])
os.sched_setaffinity(0, {cpu})
if policy == "fifo":
    os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(prio))
else:
    os.nice(prio)
for line in sys.stdin:
    d = float(line)
    t0 = time.monotonic(); end = t0 + d
    while time.monotonic() < end:
        pass
    print("%.6f %.6f" % (t0, time.monotonic()), flush=True)
"""


class Hog:
    """A spinner process pinned to `cpu`, idle until told to spin for d s."""

    def __init__(self, cpu, policy="fifo", prio=50):
        self.p = subprocess.Popen([sys.executable, "-c", HOG_SRC, str(cpu), policy, str(prio)],
                                  stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)

    def spin(self, d):
        self.p.stdin.write("%.6f\n" % d)
        self.p.stdin.flush()

    def done(self):
        t0, t1 = self.p.stdout.readline().split()
        return float(t0), float(t1)

    def close(self):
        self.p.stdin.close()
        self.p.wait()


class LogTail:
    """The daemon's log, read as it grows; the time each latch line was first seen."""

    def __init__(self, d):
        self.path, self.pos, self.latches, self.lines = d.logpath, 0, [], []
        self.stop = False
        self.t = threading.Thread(target=self.run, daemon=True)
        self.t.start()

    def run(self):
        while not self.stop:
            self.poll()
            time.sleep(0.002)

    def poll(self):
        with open(self.path) as f:
            f.seek(self.pos)
            data = f.read()
        cut = data.rfind("\n") + 1
        self.pos += len(data[:cut].encode())
        now = time.monotonic()
        for line in data[:cut].splitlines():
            self.lines.append((now, line))
            if LATCH_LINE in line:
                m = re.search(r"no cycle for (\d+) ms, (\d+) ms of it", line)
                self.latches.append((now, int(m.group(1)), int(m.group(2)), line))

    def since(self, t, text):
        return [l for (tt, l) in self.lines if tt >= t and text in l]


class Jogger:
    """The controller: Drive back and forth (+-0.1 m/s, 1 s each way) every 40 ms; after a fault
    (LOOP_STALLED or other): Stop, then Reset until accepted, and jog again."""

    def __init__(self, d, speed=0.1):
        self.c = d.conn(0, take_over=True)
        self.c.call(STOP)
        time.sleep(0.3)
        self.c.call(RESET, b"\x01")
        measure_all(self.c, plane=False)
        self.speed, self.stop, self.faults, self.resets, self.flips = speed, False, [], 0, []
        self.t = threading.Thread(target=self.run, daemon=True)
        self.t.start()

    def run(self):
        t0 = time.monotonic()
        while not self.stop:
            v = self.speed if int(time.monotonic() - t0) % 2 == 0 or not FLIP else -self.speed
            if self.flips == [] or self.flips[-1][1] != v:
                self.flips.append((time.monotonic(), v))
            r = self.c.call(DRIVE, drive(v, 0.0), timeout=5)
            for e in self.c.events():
                if e[0] == "fault_latched":
                    self.faults.append((time.monotonic(), e[3]))
            faulted = any(e[0] == "fault_latched" for e in self.c.events()) or (
                r is not None and r.type == ERROR)
            self.c.log.clear()
            if faulted:
                self.c.call(STOP)
                for _ in range(100):
                    time.sleep(0.1)
                    if ok(self.c.call(RESET, b"\x00")):
                        self.resets += 1
                        break
                self.c.log.clear()
            time.sleep(0.04)

    def close(self):
        self.stop = True
        self.t.join()
        self.c.close()


class Observer:
    def __init__(self, d, hz=500.0):
        self.c = d.conn(1)
        self.c.call(SUBSCRIBE, struct.pack("<f", hz))
        self.n, self.stop = 0, False
        self.t = threading.Thread(target=self.run, daemon=True)
        self.t.start()

    def run(self):
        while not self.stop and not self.c.closed:
            self.c.poll(0.05)
            self.n += sum(1 for m in self.c.log if m.type == TELEM)
            self.c.log.clear()

    def close(self):
        self.stop = True
        self.t.join()
        self.c.close()


def daemon(timeout, env=None, extra=None):
    o = {"drivers.kind": "sim", "stall_timeout_s": timeout}
    o.update(extra or {})
    d = Daemon(o, env=env, name="starve")
    d.start()
    return d


def latch_report(tail, t_from):
    out = []
    for (t, silent, excused, line) in tail.latches:
        if t >= t_from:
            out.append("    %s" % line.strip())
    return out


# ---------------------------------------------------------------- no-latch modes
def starve_trial(timeout, trial):
    d = daemon(timeout)
    tail = LogTail(d)
    loop, ts = pin(d.p.pid)
    say("trial %d timeout %.3f: ajard %d threads %s, ajar-loop %d on CPU %d (loadavg %s)" % (
        trial, timeout, d.p.pid, sorted(set(ts.values())), loop, LOOPCPU, loadavg()))
    jog, obs = Jogger(d), Observer(d)
    cg = None
    if MODE.startswith("cgroup"):
        cg = "/sys/fs/cgroup/cpu/ajar-attack3-%d" % os.getpid()
        os.makedirs(cg, exist_ok=True)
    hogs, t_end = [], time.monotonic() + DUR
    fifo = Hog(LOOPCPU, "fifo", 50) if MODE in ("fifo", "tear", "late") else None
    blind = Hog(OTHERCPU, "fifo", 50) if MODE == "late" else None  # keeps the supervisor off
    while time.monotonic() < t_end:
        time.sleep(rng.uniform(0.3, 1.5))
        if MODE == "none":
            continue
        if MODE == "tear":  # many short hogs: each end is a chance for a check's torn read
            t_stop = time.monotonic() + 5
            while time.monotonic() < t_stop:
                dur = rng.uniform(0.03, 0.08)
                fifo.spin(dur)
                hogs.append(("fifo", dur) + fifo.done())
                time.sleep(rng.uniform(0.01, 0.05))
            continue
        if MODE == "late":  # the supervisor looks again only after 40-85 % of the loop's wait
            dur = rng.uniform(0.3, 0.7)
            blind_dur = dur * rng.uniform(0.4, 0.85)
            fifo.spin(dur)
            blind.spin(blind_dur)
            blind.done()
            hogs.append(("late (supervisor %.2fs)" % blind_dur, dur) + fifo.done())
            continue
        if MODE == "fifo":
            dur = rng.uniform(0.2, 0.9)
            fifo.spin(dur)
            hogs.append(("fifo", dur) + fifo.done())
        elif MODE == "cfs":
            k, dur = rng.randint(1, 4), rng.uniform(0.5, 3.0)
            spinners = [Hog(LOOPCPU, "nice", 0) for _ in range(k)]
            time.sleep(0.1)  # python start-up
            for s in spinners:
                s.spin(dur)
            spans = [s.done() for s in spinners]
            for s in spinners:
                s.close()
            hogs.append(("cfs x%d" % k, dur, min(a for a, _ in spans), max(b for _, b in spans)))
        else:
            period = rng.choice([50000, 100000, 250000, 500000])
            quota = rng.randint(1000, 5000)
            dur = rng.uniform(1.0, 3.0)
            open(cg + "/cpu.cfs_period_us", "w").write(str(period))
            open(cg + "/cpu.cfs_quota_us", "w").write(str(quota))
            who = [loop] if MODE == "cgroup-loop" else list(threads(d.p.pid))
            t0 = time.monotonic()
            for t in who:
                try:
                    open(cg + "/tasks", "w").write(str(t))
                except OSError:
                    pass
            time.sleep(dur)
            for t in who:
                try:
                    open("/sys/fs/cgroup/cpu/tasks", "w").write(str(t))
                except OSError:
                    pass
            hogs.append(("cgroup %s %d/%d us" % ("loop" if MODE == "cgroup-loop" else "all",
                                                  quota, period), dur, t0, time.monotonic()))
    time.sleep(0.5)
    jog.close()
    obs.close()
    if fifo:
        fifo.close()
    if blind:
        blind.close()
    if cg:
        try:
            os.rmdir(cg)
        except OSError as e:
            say("  cgroup rmdir: %s" % e)
    tail.poll()
    lat = list(tail.latches)
    other = [f for f in jog.faults if "LOOP_STALLED" not in f[1]]
    say("  %d starvations (%s), %d telemetry frames, %d latches, %d other faults, loadavg %s" % (
        len(hogs), ", ".join("%s %.2fs" % (h[0], h[1]) for h in hogs[:6]) + (
            " ..." if len(hogs) > 6 else ""), obs.n, len(lat), len(other), loadavg()))
    for (t, silent, excused, line) in lat:
        near = [h for h in hogs if h[2] - 0.2 <= t <= h[3] + 0.5]
        say("  LATCH at +%.2f s: %s; starvation near: %s" % (
            t - tail.lines[0][0], line.strip(),
            ["%s %.2f s, latch %.0f ms after its start" % (h[0], h[1], (t - h[2]) * 1e3)
             for h in near]))
    for f in other:
        near = [h for h in hogs if h[2] - 0.2 <= f[0] <= h[3] + 1.0]
        flips = [t for t, v in jog.flips if f[0] - 2.0 <= t <= f[0]]
        say("  other fault at +%.2f s: %s; starvation near: %s; jog reversed %s" % (
            f[0] - tail.lines[0][0], f[1], ["%s %.2f s, fault %.0f ms after its start" % (
                h[0], h[1], (f[0] - h[2]) * 1e3) for h in near],
            ", ".join("%.0f ms before the fault (%+.0f ms from the starvation's start)" % (
                (f[0] - t) * 1e3, (t - near[-1][2]) * 1e3 if near else 0) for t in flips)))
    rc = d.stop()
    tail.stop = True
    longer = sum(1 for l in lat if l[1] >= timeout * 1e3 + 8)  # not the VM's 20-25 ms pauses
    return len(lat), len(other), len(hogs), rc, longer


def stop_then_reset(c, settle_s, tries=50):
    """Stop, wait settle_s, then Reset (parameters kept) until it is acknowledged (0.1 s apart);
    True when it was."""
    c.call(STOP)
    time.sleep(settle_s)
    for _ in range(tries):
        if ok(c.call(RESET, b"\x00")):
            return True
        time.sleep(0.1)
    return False


# ---------------------------------------------------------------- latch modes
def hang_trials(timeout):
    flag = "/tmp/ajar-attack3-hang-%d" % os.getpid()
    env = {}
    if MODE == "spin":
        so = "/tmp/ajar-attack3-spin.so"
        subprocess.run(["gcc", "-shared", "-fPIC", "-O1", "-o", so,
                        os.path.join(HERE, "spin_preload.c"), "-ldl"], check=True)
        env = {"LD_PRELOAD": so, "AJAR_SPIN_FILE": flag}
    else:
        env = {"AJAR_SIM_BLOCK_FILE": flag}
    d = daemon(timeout, env=env)
    tail = LogTail(d)
    loop, ts = pin(d.p.pid)
    hog = Hog(LOOPCPU, "fifo", 50)
    obs = Observer(d)
    c = d.conn(0, take_over=True)
    c.call(RESET, b"\x01")
    measure_all(c, plane=False)
    check_s = timeout / 4
    rows, misses, late = [], 0, 0
    for trial in range(TRIALS):
        stop_then_reset(c, 0.3)
        for _ in range(5):
            c.call(DRIVE, drive(0.1, 0.0))
            time.sleep(0.04)
        dur = rng.uniform(0.2, 0.9)
        offset = rng.uniform(-0.15, dur + 0.05)  # of the hang after the hog's start
        n0 = len(tail.latches)
        t_mark = time.monotonic()
        if offset < 0:
            open(flag, "w").close()
            t_hang = time.monotonic()
            time.sleep(-offset)
            hog.spin(dur)
        else:
            hog.spin(dur)
            time.sleep(offset)
            open(flag, "w").close()
            t_hang = time.monotonic()
        h0, h1 = hog.done()
        end = time.monotonic() + 3.0
        while len(tail.latches) == n0 and time.monotonic() < end:
            c.call(PING, b"\0" * 8, timeout=1)
            time.sleep(0.01)
        got = tail.latches[n0:]
        time.sleep(0.15)
        oob = tail.since(t_mark, "out-of-band emergency stop")
        os.unlink(flag)
        time.sleep(0.3)
        # the hang begins when the loop next calls the card: at once, or when the hog lets it run
        begin = t_hang if not (h0 <= t_hang <= h1) else h1
        if not got:
            misses += 1
            say("trial %d: hog %.2f s, hang at %+.0f ms of it: NO LATCH in 3 s (loadavg %s)" % (
                trial, dur, offset * 1e3, loadavg()))
            continue
        t_l, silent, excused, line = got[0]
        overlap = max(0.0, min(h1, t_l) - max(t_hang, h0))
        delay = t_l - t_hang
        excess = delay - overlap - timeout  # what is left after the hog and the timeout
        bad = excess > check_s + 0.06
        late += bad
        rows.append((delay, begin, t_l, excess))
        say("trial %d: hog %.2f s, hang at %+.0f ms of it; latch %.0f ms after the hang (%.0f ms "
            "after its begin, hog overlap %.0f ms, excess over hog+timeout %.0f ms%s); journal "
            "silent %d excused %d; oob stop: %s" % (
                trial, dur, offset * 1e3, delay * 1e3, (t_l - begin) * 1e3, overlap * 1e3,
                excess * 1e3, " LATE" if bad else "", silent, excused,
                oob[0].split("loop supervisor: ")[-1] if oob else "NONE"))
        if not oob:
            late += 1
    hog.close()
    obs.close()
    c.close()
    rc = d.stop()
    tail.stop = True
    ex = sorted(r[3] * 1e3 for r in rows)
    if ex:
        say("  timeout %.3f: excess over hog overlap + timeout (ms): min %.0f median %.0f max %.0f;"
            " loadavg %s" % (timeout, ex[0], ex[len(ex) // 2], ex[-1], loadavg()))
    return misses, late, rc


def rt_starve():
    hold = float(os.environ.get("HOG", "3"))
    d = daemon(0.02, extra={"control.realtime": "true"})
    tail = LogTail(d)
    time.sleep(0.3)
    say("journal at start: %s" % [l for _, l in tail.lines if "realtime" in l.lower()][:3])
    loop, ts = pin(d.p.pid)
    hog = Hog(LOOPCPU, "fifo", 90)
    c = d.conn(0, take_over=True)
    c.call(RESET, b"\x01")
    measure_all(c, plane=False)
    for _ in range(10):
        c.call(DRIVE, drive(0.2, 0.0))
        time.sleep(0.05)
    x0 = c.status()["odo_x"]
    samples, sampling = [], [True]

    def sample():  # the loop thread's CPU time (schedstat), every 5 ms
        path = "/proc/%d/task/%d/schedstat" % (d.p.pid, loop)
        while sampling[0]:
            samples.append((time.monotonic(), int(open(path).read().split()[0])))
            time.sleep(0.005)
    sampler = threading.Thread(target=sample, daemon=True)
    sampler.start()
    hog.spin(hold)
    time.sleep(0.2)
    t_e = time.monotonic()
    e = c.call(ESTOP, timeout=hold + 2)
    say("EmergencyStop 0.2 s into a %.1f s SCHED_FIFO-90 hog: %s after %.0f ms" % (
        hold, describe(e) if e else None, (time.monotonic() - t_e) * 1e3))
    h0, h1 = hog.done()
    time.sleep(1.0)
    sampling[0] = False
    sampler.join()
    gap, since = 0.0, samples[0][0]
    for (t0, e0), (t1, e1) in zip(samples, samples[1:]):
        if e1 != e0:
            since = t1
        gap = max(gap, t1 - since)
    say("the loop thread got no CPU time for %.0f ms at most (hog %.1f s)" % (gap * 1e3, h1 - h0))
    st = c.status()
    lat = [l for (t, s, x, l) in tail.latches]
    say("odometry: %.3f m at the EmergencyStop's send (approx), %.3f m after; travel after the "
        "stop %.3f m; fault %d; latches %s; loadavg %s" % (
            x0, st["odo_x"], st["odo_x"] - x0, st["fault"], lat, loadavg()))
    for _, l in tail.lines:
        if "stall" in l.lower() or "watchdog" in l.lower() or "fault" in l.lower():
            say("    journal: " + l.strip())
    hog.close()
    c.close()
    d.stop()
    return len(lat), st["odo_x"] - x0


if MAIN:
    say("seed %d mode %s trials %d timeouts %s DUR %.0f loop CPU %d pin others %s (loadavg %s)" % (
        SEED, MODE, TRIALS, TIMEOUTS, DUR, LOOPCPU, PIN_OTHERS, loadavg()))
    if MODE in ("none", "fifo", "tear", "late", "cfs", "cgroup", "cgroup-loop"):
        total = {}
        for timeout in TIMEOUTS:
            for trial in range(TRIALS):
                lat, other, n, rc, longer = starve_trial(timeout, trial)
                a = total.setdefault(timeout, [0, 0, 0, 0, 0])
                a[0] += lat; a[1] += other; a[2] += n; a[3] += rc != 0; a[4] += longer
        say("RESULT mode=%s seed=%d %s loadavg %s" % (MODE, SEED, "; ".join(
            "timeout %.3f: %d starvations, LOOP_STALLED latched %d (silent > timeout + 8 ms: %d), "
            "other faults %d, bad exits %d" % (t, a[2], a[0], a[4], a[1], a[3])
            for t, a in total.items()), loadavg()))
    elif MODE in ("hang", "spin"):
        parts = []
        for timeout in TIMEOUTS:
            misses, late, rc = hang_trials(timeout)
            parts.append("timeout %.3f: %d hangs, not latched %d, late or no oob stop %d, exit %s" % (
                timeout, TRIALS, misses, late, rc))
        say("RESULT mode=%s seed=%d %s loadavg %s" % (MODE, SEED, "; ".join(parts), loadavg()))
    elif MODE == "rt-starve":
        n, travel = rt_starve()
        say("RESULT mode=rt-starve seed=%d latches %d travel after the EmergencyStop %.3f m "
            "loadavg %s" % (SEED, n, travel, loadavg()))
    else:
        sys.exit(__doc__)

"""The card simulator's fault injection in a running ajard (drivers.kind sim over the simulator
library of the build): the LD_PRELOAD shim simctl_preload.c polls a control file; `ctl(line)` writes
one line ("FAIL fn code count", "DELAY us", "LAG ms", "FAULT axis kind") and waits until the shim
took it. A rule "FAIL fn 0 0" clears fn's rules (a "*" rule clears only "*" rules)."""
import glob
import os
import subprocess
import time

from ajarwire import BUILD

SIMLIB = glob.glob(os.path.join(BUILD, "drivers", "**", "libajar_gts_sim.so"), recursive=True)[0]
SHIM = "/tmp/ajar-attack-simctl-preload.so"


class SimCtl:
    def __init__(self):
        subprocess.run(["gcc", "-shared", "-fPIC", "-O1", "-o", SHIM,
                        os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                     "simctl_preload.c"), "-ldl", "-lpthread"], check=True)
        self.path = "/tmp/ajar-attack-simctl-%d" % os.getpid()
        self.env = {"LD_PRELOAD": SHIM, "AJAR_SIMCTL": self.path, "AJAR_SIMLIB": SIMLIB}
        self.overrides = {"drivers.kind": "sim", "library": '"%s"' % SIMLIB}

    def __call__(self, line):
        with open(self.path + ".tmp", "w") as f:
            f.write(line + "\n")
        os.rename(self.path + ".tmp", self.path)
        end = time.monotonic() + 2
        while os.path.exists(self.path) and time.monotonic() < end:
            time.sleep(0.005)
        assert not os.path.exists(self.path), "not applied (is the shim loaded?): " + line

"""`modesel` with the fake engine of tests/test_search.py, for subprocess
fault tests: python tests/faults/fake_modesel.py run STUDY --out DIR ...
(PYTHONPATH must hold the repository, tests/ and tests/faults/, so that
worker processes can import the fake engine and families). Each simulation
takes MODESEL_FAKE_SIM_S seconds more (default 0), so that a fault can land
while sets are being simulated."""
import os
import sys
import time

import modesel.study.search.engine
import test_search
from modesel.cli import main

DELAY_S = float(os.environ.get("MODESEL_FAKE_SIM_S", "0"))


def slow_simulate(scene, modeset=None, *, tmax=None, dt=None):
    time.sleep(DELAY_S)
    return test_search.fake_simulate(scene, modeset, tmax=tmax, dt=dt)


SLOW_ENGINE = modesel.study.search.engine.Engine(test_search.fake_load_scene, slow_simulate)

if __name__ == "__main__":
    modesel.study.search.engine.default_engine = lambda: SLOW_ENGINE
    sys.exit(main(sys.argv[1:]))

"""`modesel` with the fake engine of tests/test_search.py, for subprocess
fault tests: python tests/faults/fake_modesel.py run STUDY --out DIR ...
(PYTHONPATH must hold the repository and tests/, so that worker processes
can import the fake engine and families)."""
import sys

import modesel.study.search.engine
import test_search
from modesel.cli import main

if __name__ == "__main__":
    modesel.study.search.engine.default_engine = lambda: test_search.FAKE_ENGINE
    sys.exit(main(sys.argv[1:]))

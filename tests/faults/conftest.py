import sys
from pathlib import Path

TESTS = Path(__file__).resolve().parents[1]
if str(TESTS) not in sys.path:          # the fake engine of tests/test_search.py
    sys.path.insert(0, str(TESTS))

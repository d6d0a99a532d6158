"""The suite runs its commands by themselves: a `modesel serve` the developer
left running must not take them (tests/test_server.py starts its own)."""
import os

os.environ["MODESEL_SERVER"] = "off"

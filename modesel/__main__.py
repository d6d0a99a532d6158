from modesel.cli import entry

entry()

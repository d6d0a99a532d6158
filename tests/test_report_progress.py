"""What a person watching a run sees at its end (modesel.study.search.progress,
modesel.simulation.progress): the search bar finishes at done/done ("stopped early") when the run stops
before its budget,
and is erased when an error or an interrupt follows; the simulation line is
erased before the command's summary."""
import io

from modesel.simulation.progress import SimulationProgress
from modesel.study.search.progress import Progress


def test_bar_stopped_before_the_budget_ends_at_done_of_done(capsys):
    bar = Progress(12, "s", enabled=True, quiet=False)
    bar.set(11, 0.000539, 0)
    bar.close()
    last = capsys.readouterr().err.split("\r")[-1]
    assert "11/11 trials" in last and "stopped early]" in last and "best error 0.0539 %" in last
    assert "ETA" not in last
    assert last.endswith("\n")           # the finished bar stays, the summary follows below it


def test_bar_is_erased_when_an_error_follows(capsys):
    bar = Progress(12, "s", enabled=True, quiet=False)
    bar.set(3, 0.02, 1)
    bar.close(clear=True)
    err = capsys.readouterr().err
    assert err.endswith("\r\x1b[K") and "stopped early" not in err
    assert bar.bar is None
    bar.close()                          # closing twice is harmless


def test_bar_fits_inside_the_terminal(capsys, monkeypatch):
    import os
    import shutil
    monkeypatch.setattr(shutil, "get_terminal_size", lambda *a, **k: os.terminal_size((100, 40)))
    bar = Progress(5, "tower_free_decay", enabled=True, quiet=False)
    bar.set(2, 0.01, 0)
    bar.close(clear=True)
    lines = [x for x in capsys.readouterr().err.replace("\x1b[K", "").split("\r") if x.strip()]
    assert lines and max(len(x) for x in lines) <= 97      # room for an echoed "^C" on the same row


def test_simulation_line_counts_from_the_integration_and_is_erased():
    stream = io.StringIO()
    line = SimulationProgress("scene: ", stream=stream, after_s=0.0, every_s=0.0, enabled=True)
    line.start -= 100.0                  # 100 s of model set-up before the integration ...
    line(0.0, 20.0)
    line.first -= 10.0                   # ... then 10 s of integration for 5 simulated s
    line(5.0, 20.0)
    assert "simulated 5 of 20 s, 0.5x real time, ETA 30 s" in stream.getvalue()
    line.close()
    assert stream.getvalue().endswith("\r\x1b[K")


def test_compile_line_names_what_numba_compiles_and_how_long_it_took():
    """A cache miss (a function numba has not compiled) draws the compile line
    and ends with the total; a run that compiles nothing prints nothing; an
    interrupted one erases the line (the command's one line follows)."""
    from numba import njit

    from modesel.simulation.progress import CompileProgress

    stream = io.StringIO()
    with CompileProgress(stream=stream, enabled=True):
        pass
    assert stream.getvalue() == ""

    def brand_new(x):
        return 2.0 * x + 1.0

    stream = io.StringIO()
    with CompileProgress(stream=stream, enabled=True):
        assert njit(brand_new)(1.0) == 3.0
    text = stream.getvalue()
    assert "compiling the engine (first run only): 1 function, 0 s [now: brand_new]" in text
    assert text.endswith("\x1b[K\n") and "\rmodesel: engine compiled in " in text
    assert "(1 function); later runs load it from numba's cache" in text
    def also_new(x):
        return x * x

    stream = io.StringIO()
    try:
        with CompileProgress(stream=stream, enabled=True):
            njit(also_new)(2.0)
            raise KeyboardInterrupt
    except KeyboardInterrupt:
        pass
    assert stream.getvalue().endswith("\r\x1b[K") and "engine compiled" not in stream.getvalue()
    stream = io.StringIO()
    with CompileProgress(stream=stream, enabled=False):
        njit(lambda x: x - 1.0)(1.0)
    assert stream.getvalue() == ""

"""What a person watching a search sees: the progress bar of `modesel run`
and `modesel worker` (the compile note and line before it come from
`simulation.progress`).

- `Progress`: a tqdm bar on stderr (trials done of the budget, best error so
  far in %, failed count, elapsed and ETA), drawn only when stderr is a
  terminal and not `--quiet`; `runner.run_search` updates it after every
  finished trial (`counts`).
"""
from __future__ import annotations

import sys

from modesel.simulation.progress import REFRESH_S, compile_notice


class Progress:
    """tqdm bar of a search on stderr, shown when stderr is a terminal (or
    `enabled`) and not `quiet` (default: quiet when `enabled` is False, which
    also silences the compile notice). `set(done, best, failed)` after each trial:
    done = distinct sets evaluated by this run, best = best error so far
    (fraction, shown in %), failed = failed trials of this run."""

    def __init__(self, total: int, name: str, enabled: bool | None = None, quiet: bool | None = None):
        quiet = enabled is False if quiet is None else quiet
        enabled = (sys.stderr.isatty() if enabled is None else enabled) and not quiet
        self.bar = None
        self.done = 0
        compile_notice(quiet=quiet)
        self._stop = None
        if enabled:
            import shutil
            import threading

            from tqdm import tqdm
            # narrower than the terminal: a "^C" echoed after the bar must not wrap the line,
            # or clearing it would clear the wrapped remainder and leave the bar standing
            width = max(40, min(shutil.get_terminal_size().columns - 3, 140))
            self.bar = tqdm(total=total, desc=name, unit="trial", file=sys.stderr, leave=True, ncols=width,
                            bar_format="{desc}: {n_fmt}/{total_fmt} trials |{bar}| "
                                       "[{elapsed} elapsed, ETA {remaining}]{postfix}")
            self.bar.set_postfix_str("best error -, 0 failed")
            # redraw every REFRESH_S while a trial runs: the elapsed time moves on (a trial can take minutes)
            self._stop = threading.Event()
            threading.Thread(target=self._tick, args=(self.bar, self._stop), daemon=True).start()

    @staticmethod
    def _tick(bar, stop):
        while not stop.wait(REFRESH_S):
            bar.refresh()

    @staticmethod
    def postfix(best: float | None, failed: int) -> str:
        best_text = "-" if best is None else f"{100.0 * best:.3g} %"
        return f"best error {best_text}, {failed} failed"

    def set(self, done: int, best: float | None = None, failed: int = 0):
        if self.bar is None:
            return
        self.bar.update(max(0, done - self.done))
        self.done = max(self.done, done)
        self.bar.set_postfix_str(self.postfix(best, failed))

    def close(self, clear: bool = False):
        """End the bar. A run that stopped before its budget (tolerance met,
        space exhausted, repeats) shows done/done and "stopped early" in place
        of the ETA; `clear` (an error or an interrupt follows) removes the
        bar, so that the one-line message stands alone."""
        if self.bar is None:
            return
        self._stop.set()
        if clear:
            self.bar.leave = False
        elif self.bar.n < self.bar.total:
            self.bar.total = self.bar.n         # the ETA field says why instead (same width: never cut)
            self.bar.bar_format = self.bar.bar_format.replace("ETA {remaining}", "stopped early")
        self.bar.close()
        if clear:       # also the "^C" the terminal echoed after the bar
            self.bar.fp.write("\r\x1b[K")
            self.bar.fp.flush()
        self.bar = None


def counts(opt, since: int, criterion):
    """(distinct sets finished since trial `since`, best error so far of the
    whole study, failed since) for `Progress.set`."""
    import optuna
    TS = optuna.trial.TrialState
    done = [t for t in opt.get_trials(deepcopy=False, states=(TS.COMPLETE, TS.FAIL))
            if t.number >= since and "duplicate_of" not in t.user_attrs]
    errors = [criterion.assess(t.user_attrs["errors"]).error for t in opt.get_trials(
        deepcopy=False, states=(TS.COMPLETE,)) if t.user_attrs.get("errors")]
    return len(done), (min(errors) if errors else None), sum(1 for t in done if t.state == TS.FAIL)

"""OpenFAST input files read by their input labels (layout independent).

OpenFAST's parsers (NWTC `ParseVar`) take one value per line, "value  label
- description"; the order of lines differs between releases and the
positional readers of openfast_io follow one release only. `InputFile`
collects every labelled line of a file (up to its first OutList) by label,
so a value is found whatever the release's layout, and each value is
converted with a `ModeselError` naming the file and the label when it is
missing or malformed.
"""
from __future__ import annotations

import re
from pathlib import Path

from modesel.errors import ModeselError

_LABEL = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*(\(\d+\))?$")
_WORDS = {"true", "false", "t", "f", "default", "unused", "none"}
#: a token of a line: a quoted string (a file name may hold blanks, as OpenFAST reads it) or a word
TOKEN = re.compile(r"\"[^\"]*\"|'[^']*'|\S+")


class InputFile:
    """The labelled values of one OpenFAST input file.

    `what` names the kind of file in messages ("ServoDyn", ...)."""

    def __init__(self, path, what: str):
        self.path = Path(path)
        self.what = what
        try:
            self.lines = self.path.read_text(errors="replace").splitlines()
        except OSError as exc:
            raise ModeselError(f"cannot read the {what} file: {exc.strerror}", file=str(path)) from None
        self.values = {}          # label -> (line index, value text)
        self.outlist_at = None    # line index of the first OutList header
        for i, line in enumerate(self.lines):
            tokens = TOKEN.findall(line)      # a quoted value is one token, blanks and all
            if not tokens:
                continue
            if tokens[0] in ("OutList", "OutList_Nodal"):
                self.outlist_at = i
                break
            for j in range(1, len(tokens)):
                tok = tokens[j]
                # a description starts at "-" or "!" (a negative number in a list, "0, -10, 0", does not)
                if tok in ("-", "--") or tok.startswith("!") or (tok[0] == "-" and not re.match(r"^-[.0-9]", tok)):
                    break
                if _LABEL.match(tok) and tok.lower() not in _WORDS:
                    self.values.setdefault(tok, (i, " ".join(tokens[:j])))
                    break
                if not re.match(r'^[-+.,0-9eEdD"\']', tok) and tok.lower() not in _WORDS:
                    break

    def __contains__(self, label):
        return label in self.values

    def error(self, message, label=None) -> ModeselError:
        return ModeselError(message, file=str(self.path), field=label)

    def text(self, label: str, *alternatives) -> str:
        """The value text of `label` (or the first alternative label present)."""
        for name in (label,) + alternatives:
            if name in self.values:
                return self.values[name][1].strip()
        raise self.error(f"input missing from the {self.what} file", label)

    def label_of(self, label: str, *alternatives) -> str:
        return next((n for n in (label,) + alternatives if n in self.values), label)

    def string(self, label: str, *alternatives) -> str:
        return self.text(label, *alternatives).strip("\"'")

    def number(self, label: str, *alternatives, default=None) -> float:
        text = self.text(label, *alternatives).strip("\"'")
        if text.lower() == "default":
            if default is None:
                raise self.error("'default' is not allowed here", self.label_of(label, *alternatives))
            return float(default)
        try:
            value = float(text.split(",")[0].split()[0].replace("d", "e").replace("D", "e"))
        except (ValueError, IndexError):
            raise self.error(f"expected a number, got {text!r}", self.label_of(label, *alternatives)) from None
        if value != value or value in (float("inf"), float("-inf")):
            raise self.error(f"expected a finite number, got {text!r}", self.label_of(label, *alternatives))
        return value

    def integer(self, label: str, *alternatives, default=None) -> int:
        value = self.number(label, *alternatives, default=default)
        if value != int(value):
            raise self.error(f"expected an integer, got {self.text(label, *alternatives)!r}",
                             self.label_of(label, *alternatives))
        return int(value)

    def flag(self, label: str, *alternatives, default=None) -> bool:
        text = self.text(label, *alternatives).strip("\"'").lower()
        if text in ("true", "t"):
            return True
        if text in ("false", "f"):
            return False
        if text == "default" and default is not None:
            return bool(default)
        try:
            return float(text) != 0.0      # OpenFAST also reads 0/1 for flags
        except ValueError:
            raise self.error(f"expected True or False, got {text!r}", self.label_of(label, *alternatives)) from None

    def referenced(self, label: str) -> Path | None:
        """A file named by `label` (relative to this file's folder); None when
        the name is empty or "unused"."""
        name = self.string(label)
        if not name or name.lower() in ("unused", "none"):
            return None
        target = Path(name)
        if not target.is_absolute():
            target = self.path.parent / target
        if not target.is_file():
            raise self.error(f"referenced file '{name}' not found (looked for {target})", label)
        return target.resolve()

    def outlist(self) -> list:
        """The channel names of the file's first OutList ([] without one):
        OpenFAST's list, quoted names (several per line, separated by commas,
        semicolons or blanks) up to the line that starts with END, as typed
        (a sign prefix, OpenFAST's negated output, kept: `outputs.with_aliases`
        writes it); a line starting with '!' is a comment."""
        return [] if self.outlist_at is None else self._names_after(self.outlist_at)

    def _names_after(self, header: int) -> list:
        """The names of an OutList whose header is line `header`: quoted names
        (several per line, separated by commas, semicolons or blanks), or a
        line's first word, up to the line that starts with END; '!' lines skipped."""
        names = []
        for line in self.lines[header + 1:]:
            if line.lstrip()[:3].upper() == "END":
                break
            if line.lstrip().startswith("!"):
                continue
            quoted = re.findall(r'"([^"]*)"|\'([^\']*)\'', line)
            parts = [a or b for a, b in quoted] if quoted else line.split()[:1]
            for part in parts:
                names += [n for n in re.split(r"[,;\s]+", part) if n.strip("-_")]
        return names

    def nodal_outlist(self) -> list:
        """The quantities of the file's nodal output section (ElastoDyn's and
        AeroDyn's "Outputs for all blade stations": the OutList after
        BldNd_BladesOut), [] without one or with BldNd_BladesOut 0."""
        start = next((i for i, line in enumerate(self.lines) if line.split()[1:2] == ["BldNd_BladesOut"]), None)
        if start is None:
            return []
        try:
            blades = int(float(self.lines[start].split()[0]))
        except ValueError:
            raise self.error(f"expected a number, got {self.lines[start].split()[0]!r}", "BldNd_BladesOut") from None
        if blades <= 0:
            return []
        header = next((i for i in range(start + 1, len(self.lines))
                       if {"OutList", "OutList_Nodal"} & set(self.lines[i].split()[:2])), None)
        return [] if header is None else self._names_after(header)

    def unsupported(self, label: str, what: str):
        """The one-line error for an option modesel does not model: `what`
        names the feature ("tower shadow"), or, starting with "only", the
        values that are modelled."""
        if what.startswith("only "):
            return self.error(f"{label} = {self.text(label)} is not modelled by modesel ({what}); "
                              f"choose one of those to simulate this case", label)
        return self.error(f"{label} = {self.text(label)} ({what}) is not modelled by modesel; "
                          f"switch it off to simulate this case", label)

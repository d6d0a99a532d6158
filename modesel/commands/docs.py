"""`modesel docs study-file`: print the study-file reference (Markdown),
generated from the schema the validator uses (`modesel.study.schema`); the
same text is committed as docs/study-file.md."""
from __future__ import annotations

TOPICS = ("study-file",)


def register(sub):
    p = sub.add_parser("docs", help="print reference documentation (study-file)",
                       description=__doc__.split("\n\n")[0])
    p.add_argument("topic", choices=TOPICS, help="study-file: every table and key, metric and family")
    p.set_defaults(func=run)


def run(args) -> int:
    from modesel.study.schema import render_reference
    print(render_reference(), end="")
    return 0

"""`modesel candidates [--field F] [--json]`: list the candidate families.

For each family: the fields it describes, the most modes it provides, its
continuous parameters (name, default, range) and a one-line description.
"""
from __future__ import annotations

import json

from modesel.candidates import families
from modesel.errors import unknown_name
from modesel.modeset import FIELDS


def register(subparsers):
    p = subparsers.add_parser("candidates", help="list the assumed-mode families per field",
                              description=__doc__.splitlines()[0])
    p.add_argument("--field", help=f"only families describing this field ({', '.join(FIELDS)})")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    p.set_defaults(func=run)


def describe(field: str | None = None) -> list[dict]:
    """The families (for `field`, or all) as plain dictionaries."""
    if field is not None and field not in FIELDS:
        raise unknown_name("field", field, FIELDS, field="--field")
    return [{"name": f.name, "fields": list(f.fields), "max_count": f.max_count,
             "parameters": [{"name": p.name, "default": p.default, "low": p.low, "high": p.high,
                             "description": p.description} for p in f.parameters],
             "description": f.description}
            for f in families(field)]


def run(args) -> int:
    rows = describe(args.field)
    if args.json:
        print(json.dumps({"families": rows}, indent=2))
        return 0
    for row in rows:
        count = "any" if row["max_count"] is None else f"<= {row['max_count']}"
        print(f"{row['name']}  (modes {count}; fields: {', '.join(row['fields'])})")
        print(f"    {row['description']}")
        for p in row["parameters"]:
            print(f"    parameter {p['name']} = {p['default']:g} in [{p['low']:g}, {p['high']:g}]:"
                  f" {p['description']}")
    return 0

"""Two complete reports claim by claim: ``python -m report.compare_claims OLD/claims.json NEW/claims.json``.

Prints both summaries and headlines, then every claim added, removed or changed (verdict or the
testbed's text); a claim not printed is identical. What docs/report.md's "Results" compares with.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

TEXT_CUT = 220  # characters of a changed claim's text shown


def differences(old: dict, new: dict) -> list[str]:
    """The lines for every claim of ``old`` and ``new`` (claims.json contents) that is not identical."""
    a = {c["id"]: c for c in old["claims"]}
    b = {c["id"]: c for c in new["claims"]}
    out = []
    for key in sorted(set(a) | set(b)):
        x, y = a.get(key), b.get(key)
        if x is None:
            out.append(f"+ {key}: {y['verdict']} | {y['testbed'][:TEXT_CUT]}")
        elif y is None:
            out.append(f"- {key}: {x['verdict']}")
        elif (x["verdict"], x["testbed"]) != (y["verdict"], y["testbed"]):
            out.append(f"~ {key}: {x['verdict']} -> {y['verdict']}\n    before: {x['testbed'][:TEXT_CUT]}"
                       f"\n    after:  {y['testbed'][:TEXT_CUT]}")
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m report.compare_claims", description=__doc__.splitlines()[0])
    parser.add_argument("old", type=Path)
    parser.add_argument("new", type=Path)
    args = parser.parse_args(argv)
    old, new = (json.loads(p.read_text()) for p in (args.old, args.new))
    for label, d in (("before", old), ("after ", new)):
        print(f"summary {label}", d["summary"], "apart", d.get("summary_apart"))
        print(f"headline {label}", d["headline"].get("text"))
    print("\n".join(differences(old, new)) or "every claim identical")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

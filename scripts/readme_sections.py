#!/usr/bin/env python3
"""Fills the generated sections of the user docs from the result files.

In README.md, firmware/README.md and docs/*.md the text between `<!-- results:NAME -->` and
`<!-- /results:NAME -->` is the file RESULTS/NAME (e.g. docs/results/compare.md), copied
whole. scripts/results.sh writes the result files and then runs this script, so every
measured table in the docs is the one the last run produced and none is edited by hand.

  python3 scripts/readme_sections.py            rewrite the sections of README.md, firmware/README.md and docs/*.md
  python3 scripts/readme_sections.py --check    change nothing; exit 1 when a section differs
                                                from its file, names a file that does not
                                                exist, is not closed, or when a result file
                                                (RESULTS/*.md) is placed in no document
  --results DIR   the result files (default docs/results)
  FILE ...        the documents (default README.md, firmware/README.md and docs/*.md)
Paths are relative to the repository's root, whatever the working directory.
"""
import argparse
import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
OPEN = re.compile(r"<!-- results:([\w.-]+) -->")
SECTION = re.compile(r"<!-- results:([\w.-]+) -->.*?<!-- /results:\1 -->", re.S)


def main():
    ap = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0],
        epilog="Sections: <!-- results:NAME --> ... <!-- /results:NAME -->, NAME a file of --results.",
    )
    ap.add_argument("--check", action="store_true",
                    help="change nothing; exit 1 when a document differs from the result files")
    ap.add_argument("--results", default="docs/results", help="the result files (default docs/results)")
    ap.add_argument("files", nargs="*", help="the documents (default README.md, firmware/README.md and docs/*.md)")
    a = ap.parse_args()
    res = ROOT / a.results
    files = [ROOT / f for f in a.files] or [ROOT / "README.md", ROOT / "firmware" / "README.md", *sorted((ROOT / "docs").glob("*.md"))]

    problems, placed, changed, count = [], set(), [], 0
    for doc in files:
        text = doc.read_text()
        rel = doc.relative_to(ROOT)

        def fill(m):
            name = m.group(1)
            placed.add(name)
            src = res / name
            if not src.is_file():
                problems.append(f"{rel}: section {name}: no file {src.relative_to(ROOT)}")
                return m.group(0)
            body = src.read_text().rstrip("\n")
            return f"<!-- results:{name} -->\n{body}\n<!-- /results:{name} -->"

        new = SECTION.sub(fill, text)
        n = len(SECTION.findall(text))
        count += n
        if len(OPEN.findall(text)) != n:
            problems.append(f"{rel}: a `<!-- results:NAME -->` marker without its `<!-- /results:NAME -->`")
        if new != text:
            changed.append(str(rel))
            if not a.check:
                doc.write_text(new)
    for f in sorted(res.glob("*.md")):
        if f.name not in placed:
            problems.append(f"{f.relative_to(ROOT)}: placed in no document (add its section markers)")

    if a.check:
        problems += [f"{c}: a generated section differs from its result file "
                     f"(run python3 scripts/readme_sections.py)" for c in changed]
    for p in problems:
        print(f"readme_sections: {p}", file=sys.stderr)
    verb = "differ" if a.check else "rewritten"
    print(f"readme_sections: {count} generated sections in {len(files)} documents, "
          f"{len(changed)} {verb}")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())

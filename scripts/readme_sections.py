#!/usr/bin/env python3
"""Rewrites the README's generated sections: the text between `<!-- results:NAME -->` and
`<!-- /results:NAME -->` becomes the file RESULTS_DIR/NAME (e.g. compare.md)."""
import pathlib
import re
import sys

readme, res = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])
text = readme.read_text()


def fill(m):
    name = m.group(1)
    body = (res / name).read_text().rstrip("\n")
    return f"<!-- results:{name} -->\n{body}\n<!-- /results:{name} -->"


new = re.sub(r"<!-- results:([\w.-]+) -->.*?<!-- /results:\1 -->", fill, text, flags=re.S)
readme.write_text(new)
print(f"readme: {len(re.findall(r'<!-- results:', new))} generated sections")

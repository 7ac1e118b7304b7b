#!/usr/bin/env python3
"""Import circles between the source files of each Rust crate under a tree (an approximate reading).

Each file is a module (src/a.rs or src/a/mod.rs is `a`, src/a/b.rs is `a::b`). An edge goes from a file to
the deepest module file that a `crate::...`, `super::...` or `use crate::{...}` path in it names. Edges
between a module and its own ancestors or descendants are left out (a parent re-exporting its children and
a child naming its parent is the language's idiom, not a tangle). Prints each circle of two or more files
and a last line `N import circles`; exits 1 if there is one (a step of the test suite,
scripts/test-steps.sh). Usage: import_circles.py [--self-test] [ROOT] (default: the current
folder). `--self-test` first checks, on a small crate it writes into a temporary folder, that a
circle of two files is found and that a parent and its child are not one.
"""
import os
import re
import sys

args = sys.argv[1:]
self_test = "--self-test" in args
args = [a for a in args if a != "--self-test"]
root = args[0] if args else "."
SKIP = {"target", ".git", "tests", "benches", "examples", "fuzz", ".vm", "venv", "node_modules"}


def crates(top):
    for d, subs, files in os.walk(top):
        subs[:] = [s for s in subs if s not in SKIP and not s.startswith(".")]
        if "Cargo.toml" in files and os.path.isdir(os.path.join(d, "src")):
            yield d


def modules(src):
    mods = {}
    for d, subs, files in os.walk(src):
        subs[:] = [s for s in subs if s not in SKIP]
        for f in files:
            if not f.endswith(".rs"):
                continue
            rel = os.path.relpath(os.path.join(d, f), src)[:-3].split(os.sep)
            if rel[-1] == "mod":
                rel = rel[:-1]
            if rel and rel[-1] in ("lib", "main") and len(rel) == 1:
                rel = []
            if rel[:1] == ["bin"]:
                continue
            mods[tuple(rel)] = os.path.join(d, f)
    return mods


PATH = re.compile(r"\b(crate|super)((?:::[A-Za-z_][A-Za-z0-9_]*)+)")
GROUP = re.compile(r"\buse\s+(crate|super)((?:::[A-Za-z_][A-Za-z0-9_]*)*)::\{([^;]*)\}", re.S)


def strip_comments(text):
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    return re.sub(r"//[^\n]*", "", text)


def resolve(mods, base, names):
    path = list(base) + names
    while path and tuple(path) not in mods:
        path.pop()
    return tuple(path) if path else None


def edges_of(mods, mod, text):
    out = set()
    refs = []
    for m in GROUP.finditer(text):
        head = [p for p in m.group(2).split("::") if p]
        for item in re.split(r",\s*", m.group(3)):
            item = item.strip()
            if not item or item == "self":
                refs.append((m.group(1), head))
                continue
            refs.append((m.group(1), head + [p for p in re.split(r"::|\s|\{", item) if p][:3]))
    for m in PATH.finditer(text):
        refs.append((m.group(1), [p for p in m.group(2).split("::") if p]))
    for kind, names in refs:
        if kind == "crate":
            base = []
        else:
            base = list(mod[:-1]) if mod else []
            while names and names[0] == "super":
                names = names[1:]
                base = base[:-1]
        target = resolve(mods, base, names)
        if target is None or target == mod:
            continue
        n = min(len(target), len(mod))
        if target[:n] == mod[:n]:  # ancestor or descendant
            continue
        out.add(target)
    return out


def sccs(graph):
    index, low, stack, on, res, i = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = i[0]
        i[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            res.append(comp)

    sys.setrecursionlimit(10000)
    for v in list(graph):
        if v not in index:
            visit(v)
    return res


def circles(top, show=print):
    """The import circles of every crate below `top` (each shown as it is found)."""
    total = 0
    for crate in sorted(crates(top)):
        src = os.path.join(crate, "src")
        mods = modules(src)
        graph = {}
        for mod, path in mods.items():
            with open(path, encoding="utf-8", errors="replace") as f:
                graph[mod] = edges_of(mods, mod, strip_comments(f.read()))
        for comp in sccs(graph):
            if len(comp) > 1:
                total += 1
                files = sorted(os.path.relpath(mods[m], top) for m in comp)
                show(f"circle of {len(files)} files: " + ", ".join(files))
    return total


def check_itself():
    """A crate with one circle (a <-> b) and a parent and child naming each other (c, c::d)."""
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        src = os.path.join(tmp, "k", "src")
        os.makedirs(os.path.join(src, "c"))
        open(os.path.join(tmp, "k", "Cargo.toml"), "w").close()
        files = {
            "lib.rs": "mod a;\nmod b;\nmod c;\n",
            "a.rs": "use crate::b::B;\npub struct A;\n",
            "b.rs": "use super::a::A; // crate::c would be an edge, but not in a comment\npub struct B;\n",
            "c/mod.rs": "mod d;\nuse d::D;\n",
            "c/d.rs": "use super::C;\npub struct D;\n",
        }
        for name, text in files.items():
            with open(os.path.join(src, name), "w") as f:
                f.write(text)
        found = []
        n = circles(tmp, found.append)
        want = "circle of 2 files: k/src/a.rs, k/src/b.rs"
        if n != 1 or found != [want]:
            sys.exit(f"import_circles.py --self-test: found {found}, want [{want!r}]")


if self_test:
    check_itself()
total = circles(root)
print(f"{total} import circles")
sys.exit(1 if total else 0)

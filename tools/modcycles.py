#!/usr/bin/env python3
"""Reports import cycles between the children of a module: the engine's top-level modules
(engine/graph, engine/vk, ...), and one level deeper, the files and subfolders of each engine
module (engine/volume/data, engine/volume/render, engine/graph/execute.rs, ...); the demo library's modules likewise.

An edge A -> B is any path in A's source (a `use` tree or an inline path starting with `crate`,
`super` or `self`) that resolves into sibling B, or to a name the parent's `mod.rs` re-exports from
B. Paths are resolved the way rustc does, inline `mod tests { .. }` blocks included, so a test's
`use super::*` names its own file. A parent declaring a child is not an import, and a child using
what the parent's own `mod.rs` defines is not an edge between siblings.

Exits 1 if a cycle exists other than the mutual pairs in ALLOWED, each listed with its reason.
`--graph FOLDER` prints one folder's edges."""
import os
import re
import sys

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")

# Mutual pairs that are one concern split over two files for size, each with why.
ALLOWED = {
    ("engine/vk", "context", "pipeline"): "the context owns the lazy pipeline cache (pipeline/cache.rs), and pipelines are created and destroyed through the context",
}


def strip(text):
    text = re.sub(r"//[^\n]*", "", text)  # comments (incl. doc links)
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    text = re.sub(r"'(\\.|[^'\\])'", "' '", text)  # char literals, e.g. '{'
    return re.sub(r'"(\\.|[^"\\])*"', '""', text)  # string literals


def expand(tree):
    """Expands a `use` tree (`a::{b, c::{d, e as f}}`) into its paths, as lists of segments."""
    tree = re.sub(r"\s+", "", re.sub(r"\s+as\s+", "@", tree))

    def parse(s, i, prefix):
        out, seg = [], ""
        while i < len(s):
            c = s[i]
            if s.startswith("::{", i):
                cur = prefix + [p for p in seg.split("::") if p]
                inner, i = parse(s, i + 3, cur)
                out += inner
                seg = None
                continue
            if c == "{":
                inner, i = parse(s, i + 1, prefix)
                out += inner
                seg = None
                continue
            if c in ",}":
                if seg:
                    out.append(prefix + [p for p in seg.split("@")[0].split("::") if p])
                if c == "}":
                    return out, i + 1
                seg = ""
                i += 1
                continue
            seg = (seg or "") + c
            i += 1
        if seg:
            out.append(prefix + [p for p in seg.split("@")[0].split("::") if p])
        return out, i

    return parse(tree, 0, [])[0]


def inline_mods(text):
    """(start, end, name) of every inline `mod name { .. }` block."""
    spans = []
    for m in re.finditer(r"\bmod\s+(\w+)\s*\{", text):
        depth, i = 1, m.end()
        while i < len(text) and depth:
            depth += {"{": 1, "}": -1}.get(text[i], 0)
            i += 1
        spans.append((m.start(), i, m.group(1)))
    return spans


def module_of(crate_dir, path):
    rel = os.path.relpath(path, crate_dir)[:-3].split(os.sep)
    if rel[-1] in ("mod", "lib"):
        rel = rel[:-1]
    return rel


def paths_in(crate_dir, path):
    """Absolute module paths (lists of segments after `crate`) that the file refers to."""
    text = strip(open(path, encoding="utf-8").read())
    base = module_of(crate_dir, path)
    spans = inline_mods(text)

    def here(pos):
        inner = [s for s in spans if s[0] <= pos < s[1]]
        return base + [name for _, _, name in sorted(inner)]

    raw = []
    for m in re.finditer(r"\buse\s+([^;]*);", text):
        for p in expand(m.group(1)):
            raw.append((m.start(), p))
    for m in re.finditer(r"\b(?:crate|super|self)(?:::\w+)+", text):
        raw.append((m.start(), m.group(0).split("::")))
    out = []
    for pos, p in raw:
        mod = here(pos)
        if not p:
            continue
        if p[0] == "crate":
            out.append(p[1:])
        elif p[0] in ("super", "self"):
            cur = list(mod)
            i = 0
            while i < len(p) and p[i] in ("super", "self"):
                if p[i] == "super":
                    cur = cur[:-1]
                i += 1
            out.append(cur + p[i:])
    return out


def reexports(folder):
    """Names the folder's mod.rs (or lib.rs) re-exports, mapped to the child they come from."""
    for f in ("mod.rs", "lib.rs"):
        p = os.path.join(folder, f)
        if os.path.exists(p):
            text = strip(open(p, encoding="utf-8").read())
            names = {}
            for m in re.finditer(r"\bpub(?:\([\w:]+\))?\s+use\s+([^;]*);", text):
                for path in expand(m.group(1)):
                    if path and path[0] not in ("crate", "super", "self") and len(path) >= 2:
                        names[path[-1]] = path[0]
                    elif path and path[0] == "self" and len(path) >= 3:
                        names[path[-1]] = path[1]
            return names
    return {}


def children(folder):
    out = set()
    for e in os.listdir(folder):
        p = os.path.join(folder, e)
        if e.endswith(".rs") and e not in ("mod.rs", "lib.rs"):
            out.add(e[:-3])
        elif os.path.isdir(p) and any(f.endswith(".rs") for _, _, fs in os.walk(p) for f in fs):
            out.add(e)
    return out


def graph(crate_dir, folder):
    """Edges between the children of `folder` (a module directory inside the crate at crate_dir)."""
    prefix = module_of(crate_dir, os.path.join(folder, "mod.rs"))
    kids = children(folder)
    names = reexports(folder)
    edges = {k: set() for k in kids}
    for d, _, files in os.walk(folder):
        for f in files:
            if not f.endswith(".rs"):
                continue
            p = os.path.join(d, f)
            mod = module_of(crate_dir, p)
            if len(mod) <= len(prefix):
                continue  # the parent's own mod.rs
            a = mod[len(prefix)]
            for path in paths_in(crate_dir, p):
                if path[: len(prefix)] != prefix or len(path) <= len(prefix):
                    continue
                b = path[len(prefix)]
                b = b if b in kids else names.get(b)
                if b and b != a:
                    edges[a].add(b)
    return edges


def cycles(edges):
    index, low, stack, on, out, n = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = n[0]
        n[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(edges[v]):
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
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return out


def folders():
    """(crate dir, folder) pairs whose children must not import each other in a cycle."""
    engine = os.path.join(ROOT, "engine")
    demos = os.path.join(ROOT, "demos/src")
    yield engine, engine
    for e in sorted(os.listdir(engine)):
        if os.path.isdir(os.path.join(engine, e)):
            yield engine, os.path.join(engine, e)
    yield demos, demos
    for e in sorted(os.listdir(demos)):
        if os.path.isdir(os.path.join(demos, e)):
            yield demos, os.path.join(demos, e)


def self_test():
    """Checks the checker on a made-up crate: each case must find exactly the cycles it names."""
    import tempfile

    def run(files):
        with tempfile.TemporaryDirectory() as d:
            for path, text in files.items():
                p = os.path.join(d, path)
                os.makedirs(os.path.dirname(p), exist_ok=True)
                with open(p, "w", encoding="utf-8") as f:
                    f.write(text)
            return cycles(graph(d, os.path.join(d, "m")))

    base = {"lib.rs": "pub mod m;", "m/mod.rs": "pub mod low; pub mod high; pub use high::Thing;"}
    cases = [
        # (files, cycles expected)
        ({"m/low.rs": "pub struct L;", "m/high.rs": "use super::low::L; pub struct Thing;"}, []),
        ({"m/low.rs": "use super::high::Thing;", "m/high.rs": "use super::low::L;"}, [["high", "low"]]),
        # a back-import through the parent's re-export, and through an inline path
        ({"m/low.rs": "fn f() -> super::Thing { todo!() }", "m/high.rs": "use crate::m::low;"}, [["high", "low"]]),
        # a use tree with a nested group
        ({"m/low.rs": "use crate::m::{high::{Thing as T}};", "m/high.rs": "use super::low::L;"}, [["high", "low"]]),
        # in a test module `super::` is its own file, not the parent (whose `Thing` is high's)
        ({"m/low.rs": "pub struct Thing; mod tests { use super::Thing; }", "m/high.rs": "use super::low::L;"}, []),
        # `super::super::x` from a test module names a sibling
        ({"m/low.rs": "mod tests { use super::super::high::Thing; }", "m/high.rs": "use super::low::L;"}, [["high", "low"]]),
        # comments and strings are not imports
        ({"m/low.rs": '// use super::high::Thing;\nconst S: &str = "super::high";', "m/high.rs": "use super::low::L;"}, []),
    ]
    bad = 0
    for i, (files, want) in enumerate(cases):
        got = run({**base, **files})
        if got != want:
            bad += 1
            print(f"self-test case {i}: found {got}, expected {want}")
    print(f"self-test: {len(cases) - bad} of {len(cases)} cases pass")
    return 1 if bad else 0


def main():
    if sys.argv[1:] == ["--self-test"]:
        return self_test()
    if len(sys.argv) == 3 and sys.argv[1] == "--graph":
        folder = os.path.join(ROOT, sys.argv[2])
        crate = os.path.join(ROOT, "engine" if sys.argv[2].startswith("engine") else "demos/src")
        for a, bs in sorted(graph(crate, folder).items()):
            print(f"{a} -> {' '.join(sorted(bs))}")
        return 0
    bad = False
    for crate, folder in folders():
        name = os.path.relpath(folder, ROOT)
        edges = graph(crate, folder)
        for (f, a, b), _ in ALLOWED.items():
            if f == name and a in edges and b in edges[a] and a in edges.get(b, ()):
                edges[b].discard(a)  # an allowed pair counts as one direction
        found = cycles(edges)
        for c in found:
            bad = True
            print(f"{name}: cycle among {', '.join(c)}")
            for m in c:
                print(f"    {m} -> {', '.join(sorted(e for e in edges[m] if e in c))}")
        if not found:
            print(f"{name}: {len(edges)} modules, no cycle")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())

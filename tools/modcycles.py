#!/usr/bin/env python3
"""Reports import cycles between modules: engine/ at the level of its top-level modules
(engine/graph, engine/vk, ...), demos/src at the level of its files. An edge A -> B is any
`crate::B` path (or `super::B` from a sibling file) in A's source; a module's own children
are part of it, and a parent declaring a child is not an import. Exits 1 if a cycle exists."""
import os
import re
import sys

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")


def sources(base):
    for d, _, files in os.walk(base):
        for f in files:
            if f.endswith(".rs"):
                yield os.path.join(d, f)


def strip(text):
    text = re.sub(r"//[^\n]*", "", text)  # comments (incl. doc links)
    return re.sub(r'"(\\.|[^"\\])*"', '""', text)  # string literals


def group(base, path, depth):
    rel = os.path.relpath(path, base)[:-3].split(os.sep)
    if rel[-1] in ("mod", "lib"):
        rel = rel[:-1]
    return "::".join(rel[:depth]) or "(root)"


def graph(base, depth):
    mods = {group(base, p, depth) for p in sources(base)}
    edges = {m: set() for m in mods}
    for p in sources(base):
        a = group(base, p, depth)
        text = strip(open(p, encoding="utf-8").read())
        names = set(re.findall(r"\bcrate::(\w+)", text))
        for block in re.findall(r"\buse crate::\{([^;]*)\}", text):
            names |= set(re.findall(r"(?:^|[,{]\s*)(\w+)", block))
        if depth == 1 and a != "(root)" and os.path.basename(p) not in ("mod.rs",):
            # `super::x` from a top-level file names a sibling top-level module.
            if os.path.dirname(os.path.relpath(p, base)) == "":
                names |= set(re.findall(r"\bsuper::(\w+)", text))
        for n in names:
            if n in mods and n != a:
                edges[a].add(n)
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


bad = False
for base, depth in (("engine", 1), ("demos/src", 1), ("demos/src/limits", 1)):
    edges = graph(os.path.join(ROOT, base), depth)
    found = cycles(edges)
    for c in found:
        bad = True
        print(f"{base}: cycle among {', '.join(c)}")
        for m in c:
            print(f"    {m} -> {', '.join(sorted(e for e in edges[m] if e in c))}")
    if not found:
        print(f"{base}: {len(edges)} modules, no cycle")
sys.exit(1 if bad else 0)

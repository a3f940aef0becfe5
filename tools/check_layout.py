#!/usr/bin/env python3
"""Checks that the library's folders form a layered design: no include cycle
between families (include/fskin/<family>/, src/<family>/). Prints the folder
graph in dependency order; exits 1 naming the files of any cycle.

Usage: check_layout.py REPO_ROOT
"""
import re
import sys
from collections import defaultdict
from pathlib import Path

INCLUDE = re.compile(r'^\s*#\s*include\s+"(fskin|ops)/([^"]+)"', re.M)


def family_of_header(kind, rest):
    # fskin/models/baselines/x.h -> models; ops/broyden_search/x.h -> ops
    return "ops" if kind == "ops" else rest.split("/")[0] if "/" in rest else "fskin"


def family_of_file(root, path):
    rel = path.relative_to(root).parts
    if rel[0] == "include":
        return rel[2] if len(rel) > 3 else "fskin"
    return rel[1]  # src/<family>/...


def main():
    root = Path(sys.argv[1]).resolve()
    files = [p for p in (root / "include" / "fskin").rglob("*") if p.suffix in (".h", ".cuh")]
    files += [p for p in (root / "src").rglob("*") if p.suffix in (".h", ".cuh", ".cpp", ".cu")]
    files = [p for p in files if "cli" not in p.relative_to(root).parts and p.name != "pch.h"]
    edges = defaultdict(lambda: defaultdict(list))  # family -> family -> [files]
    for path in files:
        source = family_of_file(root, path)
        for kind, rest in INCLUDE.findall(path.read_text()):
            if kind == "fskin" and rest == "version.h":
                continue
            target = family_of_header(kind, rest)
            if target != source:
                edges[source][target].append(str(path.relative_to(root)))

    families = sorted(set(edges) | {t for s in edges for t in edges[s]})
    # Tarjan's strongly connected components.
    index, low, stack, on_stack, components = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in edges[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            components.append(component)

    for v in families:
        if v not in index:
            visit(v)
    cycles = [c for c in components if len(c) > 1]
    # Components come out dependencies first.
    for c in components:
        for v in c:
            print(f"{v:14} -> {', '.join(sorted(edges[v])) or '-'}")
    if cycles:
        for c in cycles:
            print(f"\ninclude cycle between {', '.join(sorted(c))}:")
            for s in sorted(c):
                for t in sorted(edges[s]):
                    if t in c:
                        print(f"  {s} -> {t}: {', '.join(edges[s][t][:3])}")
        return 1
    print(f"\n{len(families)} families, no include cycle")
    return 0


if __name__ == "__main__":
    sys.exit(main())

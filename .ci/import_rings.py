#!/usr/bin/env python3
"""Finds import rings among a crate's modules: a module that imports another that imports
it back, directly or around a ring. Usage: import_rings.py SRC_DIR; exit 1 and the rings
printed when there are any.

A module is a file (`a/b.rs` or `a/b/mod.rs` is `a::b`). Its imports are the `crate::`,
`super::`, `self::` and child-module paths in its `use` lines and its code, outside its
`#[cfg(test)]` module. An import between a module and one it contains is not counted (a
parent re-exports its children, a child uses its parent's items); any other import counts
between the two siblings that hold the importer and the imported under their common
parent, so `a::x::p -> a::y::q` is `a::x -> a::y`."""
import os, re, sys

def module_of(root, path):
    rel = os.path.relpath(path, root)[:-3].split(os.sep)
    if rel[-1] in ("mod", "lib", "main"):
        rel = rel[:-1]
    return tuple(rel)

def strip(text):
    text = re.sub(r"//[^\n]*", "", text)
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    text = re.sub(r'"(\\.|[^"\\])*"', '""', text)
    m = re.search(r"#\[cfg\(test\)\]\s*(pub\s+)?mod\s+\w+\s*\{", text)
    if m:
        text = text[: m.start()]
    return text

def expand(tree):
    """Expand a use tree 'a::{b, c::{d, e}}' into paths."""
    tree = tree.strip()
    i = tree.find("{")
    if i < 0:
        return [tree.split(" as ")[0].strip()]
    prefix = tree[:i]
    inner = tree[i + 1 : tree.rfind("}")]
    parts, depth, cur = [], 0, ""
    for ch in inner:
        if ch == "," and depth == 0:
            parts.append(cur); cur = ""
            continue
        depth += ch == "{"
        depth -= ch == "}"
        cur += ch
    parts.append(cur)
    out = []
    for p in parts:
        if p.strip():
            for e in expand(p):
                out.append((prefix + e) if e != "self" else prefix.rstrip(":"))
    return out

def main(root):
    modules = {}
    for dirpath, _, files in os.walk(root):
        for f in files:
            if f.endswith(".rs"):
                p = os.path.join(dirpath, f)
                modules[module_of(root, p)] = p
    edges = {m: set() for m in modules}
    def resolve(cur, path):
        segs = [s for s in path.split("::") if s]
        if not segs: return None
        if segs[0] == "crate": base, segs = (), segs[1:]
        elif segs[0] in ("super", "self"):
            base = cur
            while segs and segs[0] in ("super", "self"):
                if segs[0] == "super": base = base[:-1]
                segs = segs[1:]
        elif cur + (segs[0],) in modules:
            base = cur
        else:
            return None
        best = base
        for k in range(len(segs) + 1):
            cand = base + tuple(segs[:k])
            if cand in modules: best = cand
        return best if best in modules else None
    for m, p in modules.items():
        text = strip(open(p).read())
        paths = []
        for u in re.finditer(r"\buse\s+([^;]+);", text, flags=re.S):
            paths += expand(re.sub(r"\s+", " ", u.group(1)))
        paths += re.findall(r"(?<!::)\b\w+(?:::\w+)+", text)
        for path in paths:
            t = resolve(m, path.strip())
            if t is None or t == m[: len(t)] or m == t[: len(m)]:
                continue  # itself, or a module and the modules it owns
            k = 0
            while m[k] == t[k]:
                k += 1
            edges[m[: k + 1]].add(t[: k + 1])  # siblings under the common parent
    # Tarjan SCC
    index, low, stack, on, out, n = {}, {}, [], set(), [], [0]
    sys.setrecursionlimit(10000)
    def sc(v):
        index[v] = low[v] = n[0]; n[0] += 1; stack.append(v); on.add(v)
        for w in edges[v]:
            if w not in index: sc(w); low[v] = min(low[v], low[w])
            elif w in on: low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop(); on.discard(w); comp.append(w)
                if w == v: break
            if len(comp) > 1: out.append(comp)
    for v in edges:
        if v not in index: sc(v)
    for comp in out:
        print("ring:", ", ".join("::".join(c) or "crate" for c in sorted(comp)))
        for a in sorted(comp):
            for b in sorted(edges[a]):
                if b in comp: print("   ", "::".join(a), "->", "::".join(b))
    return len(out)

if __name__ == "__main__":
    sys.exit(1 if main(sys.argv[1]) else 0)

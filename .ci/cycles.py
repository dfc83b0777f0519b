#!/usr/bin/env python3
"""Import circles in a Rust crate's src/: fails (exit 1) when files use each other in a
circle, or when two sibling folders (at any depth: src/a and src/b, src/method/paper and
src/method/beyond) each use something of the other. Reads `use` lines and `crate::`,
`super::` and `self::` paths in the code, comments and test modules left out
(`*_tests.rs` / `tests.rs` files and `#[cfg(...test...)] mod NAME { ... }` blocks):
text, not the compiler, which is enough for a crate that spells its paths plainly.

Usage: python3 .ci/cycles.py [SRC_DIR]"""
import os
import re
import sys

SRC = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else "src")


def module_of(path):
    """src/a/b.rs -> ('a', 'b'); src/a/mod.rs -> ('a',); src/lib.rs -> ()"""
    parts = os.path.relpath(path, SRC)[:-3].split(os.sep)
    if parts[-1] in ("mod", "lib", "main"):
        parts = parts[:-1]
    return tuple(parts)


FILES = {}
for root, _, names in os.walk(SRC):
    for name in names:
        if name.endswith(".rs") and not name.endswith("tests.rs"):
            path = os.path.join(root, name)
            FILES[module_of(path)] = path


def strip(text):
    text = re.sub(r"//[^\n]*", "", text)
    # test modules, inline: from the attribute to the end of the brace block
    out, i = [], 0
    for m in re.finditer(r"#\[cfg\([^\]]*\btest\b[^\]]*\)\]\s*(?:#\[[^\]]*\]\s*)*mod\s+\w+\s*[{;]", text):
        if m.start() < i:
            continue
        out.append(text[i:m.start()])
        if text[m.end() - 1] == ";":
            i = m.end()
            continue
        depth, j = 1, m.end()
        while j < len(text) and depth:
            depth += {"{": 1, "}": -1}.get(text[j], 0)
            j += 1
        i = j
    out.append(text[i:])
    return "".join(out)


def expand(s):
    """'a::{b, c::{d, e}}' -> ['a::b', 'a::c::d', 'a::c::e']"""
    i = s.find("{")
    if i < 0:
        return [s.strip()]
    depth = 0
    for j in range(i, len(s)):
        depth += {"{": 1, "}": -1}.get(s[j], 0)
        if depth == 0:
            break
    parts, depth, cur = [], 0, ""
    for ch in s[i + 1:j]:
        if ch == "," and depth == 0:
            parts.append(cur)
            cur = ""
            continue
        depth += {"{": 1, "}": -1}.get(ch, 0)
        cur += ch
    parts.append(cur)
    return [x for p in parts if p.strip() for x in expand(s[:i] + p.strip() + s[j + 1:])]


def resolve(path):
    for k in range(len(path), -1, -1):
        if tuple(path[:k]) in FILES:
            return tuple(path[:k])
    return None


EDGES = {m: set() for m in FILES}
for mod, path in FILES.items():
    text = strip(open(path, encoding="utf-8", errors="replace").read())
    paths = [p for u in re.findall(r"\buse\s+([^;]+);", text) for p in expand(" ".join(u.split()))]
    paths += re.findall(r"\b(?:crate|super|self)(?:::[A-Za-z_]\w*)+", text)
    here = list(mod) if os.path.basename(path) in ("mod.rs", "lib.rs") else list(mod[:-1])
    for p in paths:
        seg = [x for x in p.replace(" ", "").split("::") if x]
        if not seg:
            continue
        if seg[0] == "crate":
            target = seg[1:]
        elif seg[0] in ("super", "self"):
            base = list(here) if seg[0] == "self" else list(mod)
            while seg and seg[0] == "super":
                base, seg = base[:-1], seg[1:]
            if seg and seg[0] == "self":
                seg = seg[1:]
            target = base + seg
        else:
            continue
        t = resolve(target)
        # a module's own children are its structure, not a tie
        if t is not None and t != mod and t[: len(mod)] != mod:
            EDGES[mod].add(t)

# circles of files: strongly connected components (Tarjan)
index, low, stack, on, circles = {}, {}, [], set(), []
sys.setrecursionlimit(10000)


def strong(v):
    index[v] = low[v] = len(index)
    stack.append(v)
    on.add(v)
    for w in EDGES[v]:
        if w not in index:
            strong(w)
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
            circles.append(comp)


for v in FILES:
    if v not in index:
        strong(v)

# sibling folders that use each other: for files a and b, the first folders where
# their paths part, when both are folders (a file beside a folder is not a folder)
folders = {m[: k + 1] for m, p in FILES.items() for k in range(len(m))
           if os.path.isdir(os.path.join(SRC, *m[: k + 1]))}
uses = set()
for a, targets in EDGES.items():
    for b in targets:
        k = 0
        while k < min(len(a), len(b)) and a[k] == b[k]:
            k += 1
        fa, fb = a[: k + 1], b[: k + 1]
        if fa != fb and fa in folders and fb in folders and len(fa) == len(fb):
            uses.add((fa, fb))
pairs = sorted({tuple(sorted((a, b))) for a, b in uses if (b, a) in uses})

for c in circles:
    print("circle of files: " + ", ".join(sorted(os.path.relpath(FILES[m], os.path.dirname(SRC)) for m in c)))
for a, b in pairs:
    print("folders that use each other: %s <-> %s" % ("/".join(a), "/".join(b)))
print("%d circles of files, %d pairs of folders that use each other" % (len(circles), len(pairs)))
sys.exit(1 if circles or pairs else 0)

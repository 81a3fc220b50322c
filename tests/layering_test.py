#!/usr/bin/env python3
"""The library's layers (docs/architecture.md): a file in ref/<layer>/ (or variants/) includes
rubref headers only from its own layer or those before it in LAYERS. Exit 1 naming every include
that breaks the order, or a folder of ref/ that is in no layer.
    layering_test.py <source dir>"""
import pathlib
import re
import sys

# In order; folders on one line share a layer.
LAYERS = [["base"], ["format"], ["model", "variants"], ["integrate"], ["analysis", "orbits"], ["identification"], ["rig"], ["loop"], ["tracking"],
          ["validation"], ["study"], ["app"], ["cli"]]
RANK = {folder: i for i, layer in enumerate(LAYERS) for folder in layer}


def layer_of(path):
    parts = pathlib.PurePosixPath(path).parts
    if parts[0] == "variants":
        return "variants"
    return parts[1] if parts[0] == "ref" and len(parts) > 2 else None


top = pathlib.Path(sys.argv[1])
problems = []
for folder in sorted(p.name for p in (top / "ref").iterdir() if p.is_dir()):
    if folder not in RANK:
        problems.append(f"ref/{folder}/ is in no layer (tests/layering_test.py, docs/architecture.md)")
checked = 0
for root in ("ref", "variants"):
    for f in sorted((top / root).rglob("*.[hc]pp")):
        rel = f.relative_to(top).as_posix()
        own = layer_of(rel)
        if own is None:
            continue
        checked += 1
        for inc in re.findall(r'#include "((?:ref|variants)/[^"]+)"', f.read_text()):
            other = layer_of(inc)
            if other is not None and RANK[other] > RANK[own]:
                problems.append(f"{rel} ({own}) includes {inc} ({other}), a layer after its own")
if checked == 0:
    problems.append("no file found under ref/ or variants/")
print("\n".join(problems) if problems else f"layering: {checked} files, every include from its own layer or one before it")
sys.exit(1 if problems else 0)

#!/usr/bin/env python3
"""The library's layers (docs/architecture.md): a file in ref/<layer>/ (or variants/) includes
rubref headers only from its own layer or those before it in LAYERS. Exit 1 naming every include
that breaks the order, or a folder of ref/ that is in no layer.
    layering_test.py <source dir>     check the tree
    layering_test.py --self-test      check the checker on made-up trees (it must catch an upward
                                      include, and pass a downward one)"""
import pathlib
import re
import sys
import tempfile

# In order, one folder per layer: a layer may include only itself and the layers before it.
LAYERS = ["base", "format", "model", "variants", "integrate", "run", "analysis", "orbits", "sweep",
          "inference", "identification", "rig", "loop", "tracking", "validation", "study", "app", "cli"]
RANK = {folder: i for i, folder in enumerate(LAYERS)}


def layer_of(path):
    parts = pathlib.PurePosixPath(path).parts
    if parts[0] == "variants":
        return "variants"
    return parts[1] if parts[0] == "ref" and len(parts) > 2 else None


def problems_in(top):
    """Every include that breaks the order, and every folder of ref/ in no layer; [] if none."""
    problems = []
    for folder in sorted(p.name for p in (top / "ref").iterdir() if p.is_dir()):
        if folder not in RANK:
            problems.append(f"ref/{folder}/ is in no layer (tests/layering_test.py, docs/architecture.md)")
    checked = 0
    for root in ("ref", "variants"):
        for f in sorted((top / root).rglob("*.[hc]pp")):
            rel = f.relative_to(top).as_posix()
            own = layer_of(rel)
            if own is None or own not in RANK:
                continue
            checked += 1
            for inc in re.findall(r'#include "((?:ref|variants)/[^"]+)"', f.read_text()):
                other = layer_of(inc)
                if other is not None and RANK.get(other, len(LAYERS)) > RANK[own]:
                    problems.append(f"{rel} ({own}) includes {inc} ({other}), a layer after its own")
    if checked == 0:
        problems.append("no file found under ref/ or variants/")
    return problems, checked


def self_test():
    """Made-up trees with one include each: the checker must flag exactly the upward ones."""
    cases = [  # (file, its include, flagged?)
        ("ref/analysis/a.hpp", "ref/orbits/b.hpp", True),      # the issue-46 case: analysis -> orbits
        ("ref/run/a.hpp", "ref/analysis/b.hpp", True),
        ("ref/model/a.hpp", "variants/b.hpp", True),
        ("ref/base/a.cpp", "ref/cli/b.hpp", True),
        ("ref/orbits/a.hpp", "ref/analysis/b.hpp", False),
        ("variants/a.hpp", "ref/model/b.hpp", False),
        ("ref/sweep/a.cpp", "ref/sweep/b.hpp", False),
    ]
    failures = []
    for file, include, flagged in cases:
        with tempfile.TemporaryDirectory() as d:
            top = pathlib.Path(d)
            for folder in LAYERS:
                (top / ("variants" if folder == "variants" else f"ref/{folder}")).mkdir(parents=True)
            (top / file).write_text(f'#include "{include}"\n')
            problems, _ = problems_in(top)
            if bool(problems) != flagged:
                failures.append(f"{file} including {include}: expected {'a' if flagged else 'no'} problem, got {problems}")
    with tempfile.TemporaryDirectory() as d:
        top = pathlib.Path(d)
        (top / "ref/base").mkdir(parents=True)
        (top / "ref/base/a.hpp").write_text("")
        (top / "ref/newlayer").mkdir()
        if not any("in no layer" in p for p in problems_in(top)[0]):
            failures.append("a folder of ref/ in no layer was not flagged")
    print("\n".join(failures) if failures else f"layering self-test: {len(cases) + 1} made-up trees, each judged right")
    return 1 if failures else 0


if __name__ == "__main__":
    if sys.argv[1:] == ["--self-test"]:
        sys.exit(self_test())
    problems, checked = problems_in(pathlib.Path(sys.argv[1]))
    print("\n".join(problems) if problems else f"layering: {checked} files, every include from its own layer or one before it")
    sys.exit(1 if problems else 0)

#!/usr/bin/env python3
"""The real RK-4 run-up (docs/real-data.md) as a regression test: scripts/real-data with this build
against docs/real-data/report.json, the numbers the docs show (scripts/update-doc-real-data wrote
them). Numbers agree to 1e-6 relative (another compiler or optimisation level moves the fit's last
digits, never its sixth); the verdicts, claims and effects exactly; the one-line texts that print
numbers to three digits (summaries, estimates, a verdict's reasons) are not compared.
    real_data_test.py <rubref> <source dir>"""
import json
import os
import pathlib
import subprocess
import sys
import tempfile

RELATIVE = 1e-6
SKIP = {"generator", "source", "summary", "estimates", "reasons", "reason"}

rubref, top = sys.argv[1], pathlib.Path(sys.argv[2])
expected = json.loads((top / "docs" / "real-data" / "report.json").read_text())
with tempfile.TemporaryDirectory() as tmp:
    out = pathlib.Path(tmp) / "rk4"
    subprocess.run([str(top / "scripts" / "real-data"), str(out), "--no-figures"], check=True, env=dict(os.environ, RUBREF=rubref),
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    got = json.loads((out / "report.json").read_text())

problems = []


def compare(a, b, where):
    if isinstance(a, dict):
        if not isinstance(b, dict) or set(a) != set(b):
            problems.append(f"{where}: keys {sorted(a) if isinstance(a, dict) else a} != {sorted(b) if isinstance(b, dict) else b}")
            return
        for k in a:
            if k not in SKIP:
                compare(a[k], b[k], f"{where}.{k}")
    elif isinstance(a, list):
        if not isinstance(b, list) or len(a) != len(b):
            problems.append(f"{where}: {a} != {b}")
            return
        for i, (x, y) in enumerate(zip(a, b)):
            compare(x, y, f"{where}[{i}]")
    elif isinstance(a, bool) or isinstance(a, str) or a is None:
        if a != b:
            problems.append(f"{where}: expected {a!r}, got {b!r}")
    elif isinstance(a, (int, float)):
        if not isinstance(b, (int, float)) or abs(a - b) > RELATIVE * max(abs(a), abs(b)) + 1e-300:
            problems.append(f"{where}: expected {a!r}, got {b!r}")
    elif a != b:
        problems.append(f"{where}: expected {a!r}, got {b!r}")


compare(expected, got, "report")
if problems:
    print("\n".join(problems[:20]))
    sys.exit(1)
v = got["verdict"]
print(f"real data: the RK-4 run-up's report matches docs/real-data/report.json (effects {v['named']}, tentative {v['tentative']}, "
      f"claim {v['claim']})")

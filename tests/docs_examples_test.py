#!/usr/bin/env python3
"""Every code block of README.md and docs/*.md that is meant to run, run as a new user would:
against this build installed into a fresh prefix (bin/ on PATH, the Python package on
PYTHONPATH), in an empty folder holding links to the source tree's golden/, data/ and docs/.

A fence's first word says what the block is: `python` and `sh` blocks are code and run (a
document's blocks in order, in one folder, so a later block may use an earlier one's files);
`cpp` and `cmake` are code too. A code block that cannot run in a test says why in its info
string: "```sh not-run: needs a SLURM cluster". `text` (or nothing) is a transcript, a usage
synopsis or a file sample, never run. A code block without a reason to be skipped is run.

    docs_examples_test.py <build dir> <source dir> <python> <python install dir> [document ...]
"""

import os
import pathlib
import re
import subprocess
import sys
import tempfile
import time

CODE = {"python", "sh", "cpp", "cmake"}
RUNS = {"python", "sh"}
FENCE = re.compile(r"^```(.*)$")


def blocks(path):
    """(line, language, info, text) of each fenced block."""
    out, open_at, info, lines = [], None, "", []
    for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        m = FENCE.match(line)
        if m and open_at is None:
            open_at, info, lines = n, m.group(1).strip(), []
        elif m and open_at is not None:
            out.append((open_at, (info.split() or [""])[0], info, "\n".join(lines) + "\n"))
            open_at = None
        elif open_at is not None:
            lines.append(line)
    if open_at is not None:
        raise SystemExit(f"{path}:{open_at}: the block is never closed")
    return out


def main():
    build, src, python, python_dir = map(pathlib.Path, sys.argv[1:5])
    src = src.resolve()
    wanted = set(sys.argv[5:])
    documents = [src / "README.md"] + sorted((src / "docs").glob("*.md"))
    with tempfile.TemporaryDirectory(prefix="rubref-docs-") as tmp:
        tmp = pathlib.Path(tmp)
        prefix = tmp / "prefix"
        done = subprocess.run(["cmake", "--install", str(build), "--prefix", str(prefix)], capture_output=True, text=True)
        if done.returncode != 0:
            raise SystemExit("cmake --install failed: " + done.stderr.strip().splitlines()[-1])
        env = dict(os.environ)
        env["PATH"] = f"{prefix / 'bin'}:{env.get('PATH', '/usr/bin:/bin')}"
        env["PYTHONPATH"] = str(prefix / python_dir)
        env.pop("RUBREF_GOLDEN_DIR", None)  # the installed package must find its own golden cases
        env["MPLBACKEND"] = "Agg"
        failures, ran, skipped = [], 0, []
        for doc in documents:
            name = str(doc.relative_to(src))
            if wanted and name not in wanted:
                continue
            work = tmp / "work" / name.replace("/", "_")
            work.mkdir(parents=True)
            for link in ("golden", "data", "docs", "scripts"):
                (work / link).symlink_to(src / link)
            for line, lang, info, text in blocks(doc):
                where = f"{name}:{line}"
                if "not-run:" in info:
                    if lang not in CODE:
                        failures.append(f"{where}: 'not-run:' on a block that is not code ({lang or 'no language'})")
                    reason = info.split("not-run:", 1)[1].strip()
                    if not reason:
                        failures.append(f"{where}: 'not-run:' without a reason")
                    skipped.append(f"{where} ({reason})")
                    continue
                if lang not in CODE:
                    continue
                if lang not in RUNS:
                    failures.append(f"{where}: a {lang} block can only be read here: give it 'not-run: <why>'")
                    continue
                command = [str(python), "-c", text] if lang == "python" else ["bash", "-euo", "pipefail", "-c", text]
                start = time.monotonic()
                done = subprocess.run(command, cwd=work, env=env, capture_output=True, text=True)
                seconds = time.monotonic() - start
                ran += 1
                print(f"{where}: {lang} block, exit {done.returncode}, {seconds:.1f} s", flush=True)
                if done.returncode != 0:
                    tail = "\n    ".join((done.stderr or done.stdout).strip().splitlines()[-6:])
                    failures.append(f"{where}: the {lang} block failed (exit {done.returncode}):\n    {tail}")
        for s in skipped:
            print(f"not run: {s}")
        if failures:
            print("\n".join(failures), file=sys.stderr)
            raise SystemExit(f"{len(failures)} docs example(s) failed")
        if ran == 0:
            raise SystemExit("no docs example ran")
        print(f"{ran} docs example block(s) ran on the installed package")


if __name__ == "__main__":
    main()

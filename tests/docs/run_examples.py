#!/usr/bin/env python3
r"""Run every shell and Python example of the README, docs/ and the folders' indexes.

    tests/docs/run_examples.py FPKBENCH_BIN [MARKDOWN...] [--list] [--keep DIR]

Each fenced block marked ```sh, ```bash or ```python is run as written: shell blocks by
bash with `set -euo pipefail`, Python blocks by the `python3` on PATH (CI puts a virtualenv
with the built wheel and tests/docs/requirements.txt first). The blocks of one document run
in order, in a scratch directory of their own holding copies of the project's scenarios,
models, studies, data tables and scripts, with `fpkbench` on PATH (and at
target/release/fpkbench) being FPKBENCH_BIN. A block fails when it exits with another
status than expected (0 unless stated) or runs over its time limit; the runner then prints
the document, line, block and the end of its output, and exits 1 after the rest have run.

An HTML comment directly above a fence (one directive per comment, several allowed; they do
not show when the markdown is rendered) changes how the block runs:

    <!-- example: skip: REASON -->         not run; the reason is printed (a cluster
                                            submission, a record that is not shipped, a
                                            step CI runs as its own phase)
    <!-- example: file: NAME -->           not run: the block is written to NAME in the
                                            scratch directory before any block runs (a script
                                            another block calls; in any language, e.g. a
                                            model file in ```toml)
    <!-- example: sub: OLD => NEW -->      replace the text OLD with NEW before running (to
                                            shorten a study: `--seeds 50 => --seeds 2`); OLD
                                            must occur, so a stale directive fails; `\n` in either
                                            is a line break
    <!-- example: edit: PATH: OLD => NEW -->  the same in a file of the scratch directory
    <!-- example: exit: N (REASON) -->     the block is expected to exit with status N
    <!-- example: timeout: SECONDS -->     the time limit (default 300 s)
"""
import argparse
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
# What the examples may read, copied into every document's scratch directory.
COPIED = ["scenarios", "models", "studies", "data", "docs/slurm", "tests/interop"]
RUN_LANGS = {"sh": "sh", "bash": "sh", "python": "python"}
FENCE = re.compile(r"^(```+|~~~+)\s*([A-Za-z0-9_+-]*)")
DIRECTIVE = re.compile(r"^<!--\s*example:\s*(skip|file|sub|edit|exit|timeout):\s*(.*?)\s*-->\s*$")


class Block:
    def __init__(self, doc, line, lang, text, directives):
        self.doc, self.line, self.lang, self.text = doc, line, lang, text
        self.directives = directives  # [(name, argument)]

    def where(self):
        return f"{self.doc.relative_to(ROOT)}:{self.line}"

    def first(self, name):
        return next((arg for n, arg in self.directives if n == name), None)


def blocks_of(doc):
    """The runnable fenced blocks of one markdown file, with the directives above each."""
    lines = doc.read_text(encoding="utf-8").splitlines()
    found, i = [], 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        fence, lang = m.group(1), m.group(2).lower()
        start, body = i, []
        i += 1
        while i < len(lines) and not lines[i].startswith(fence):
            body.append(lines[i])
            i += 1
        i += 1
        directives, j = [], start - 1
        while j >= 0 and lines[j].startswith("<!--"):
            d = DIRECTIVE.match(lines[j])
            if not d:
                sys.exit(f"{doc.relative_to(ROOT)}:{j + 1}: not an example directive: {lines[j]}")
            directives.insert(0, (d.group(1), d.group(2)))
            j -= 1
        if lang in RUN_LANGS:
            found.append(Block(doc, start + 1, RUN_LANGS[lang], "\n".join(body) + "\n", directives))
        elif directives and all(kind == "file" for kind, _ in directives):
            # A file another block reads (a model file, a table): written, never run.
            found.append(Block(doc, start + 1, "file", "\n".join(body) + "\n", directives))
        elif directives:
            sys.exit(f"{doc.relative_to(ROOT)}:{start + 1}: example directives above a "
                     f"```{lang} block, which is never run")
    return found


def split_sub(arg, where):
    if " => " not in arg:
        sys.exit(f"{where}: a sub or edit directive needs `OLD => NEW`, not {arg!r}")
    old, new = arg.split(" => ", 1)
    return old.replace("\\n", "\n"), new.replace("\\n", "\n")


def scratch_for(doc, base, binary):
    """A fresh directory holding copies of what the examples read, fpkbench on PATH."""
    work = base / doc.relative_to(ROOT).as_posix().replace("/", "_").removesuffix(".md")
    work.mkdir(parents=True)
    for rel in COPIED:
        if (ROOT / rel).exists():
            shutil.copytree(ROOT / rel, work / rel)
    (work / "bin").mkdir()
    (work / "bin" / "fpkbench").symlink_to(binary)
    (work / "target" / "release").mkdir(parents=True)
    (work / "target" / "release" / "fpkbench").symlink_to(binary)
    return work


def prepared(block, work):
    """The block's text after its `sub` directives, and the `edit`s made in the scratch copy."""
    text = block.text
    for name, arg in block.directives:
        if name == "sub":
            old, new = split_sub(arg, block.where())
            if old not in text:
                return None, f"sub: {old!r} does not occur in the block"
            text = text.replace(old, new)
        elif name == "edit":
            path, _, rest = arg.partition(": ")
            old, new = split_sub(rest, block.where())
            target = work / path
            if not target.is_file():
                return None, f"edit: {path} is not a file of the scratch directory"
            content = target.read_text(encoding="utf-8")
            if old not in content:
                return None, f"edit: {old!r} does not occur in {path}"
            target.write_text(content.replace(old, new), encoding="utf-8")
    return text, None


def run_block(block, work, env):
    text, problem = prepared(block, work)
    if problem:
        return False, problem, 0.0
    # `exit: N (why)`: the status, then the reason it is not 0.
    expected = int((block.first("exit") or "0").split()[0])
    limit = float(block.first("timeout") or 300)
    if block.lang == "sh":
        script = work / f".example-{block.line}.sh"
        script.write_text("set -euo pipefail\n" + text, encoding="utf-8")
        cmd = ["bash", str(script)]
    else:
        script = work / f".example-{block.line}.py"
        script.write_text(text, encoding="utf-8")
        cmd = ["python3", str(script)]
    started = time.monotonic()
    # A session of its own, so that a block over its limit is stopped with everything it
    # started (a cargo build, a study's threads).
    proc = subprocess.Popen(cmd, cwd=work, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, start_new_session=True)
    try:
        stdout, _ = proc.communicate(timeout=limit)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        stdout, _ = proc.communicate()
        out = (stdout or b"").decode("utf-8", "replace")
        return False, f"over its time limit of {limit:.0f} s\n{tail(out)}", limit
    took = time.monotonic() - started
    out = stdout.decode("utf-8", "replace")
    if proc.returncode != expected:
        return False, f"exit {proc.returncode}, expected {expected}\n{tail(out)}", took
    return True, "", took


def tail(out, n=25):
    lines = out.rstrip().splitlines()
    return "\n".join(("    " + l) for l in lines[-n:])


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("binary", type=Path)
    p.add_argument("docs", nargs="*", type=Path)
    p.add_argument("--list", action="store_true", help="list the blocks and directives; run nothing")
    p.add_argument("--keep", type=Path, help="the scratch directories go here and are kept")
    args = p.parse_args()
    docs = [d.resolve() for d in args.docs] or [
        ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")),
        *(ROOT / d / "README.md" for d in ("data", "models", "studies"))]
    binary = args.binary.resolve()
    if not args.list and not os.access(binary, os.X_OK):
        sys.exit(f"{binary}: not an executable")
    base = args.keep.resolve() if args.keep else Path(tempfile.mkdtemp(prefix="fpk-doc-examples-"))
    failures, ran, skipped, total = [], 0, 0, time.monotonic()
    for doc in docs:
        blocks = blocks_of(doc)
        if args.list:
            for b in blocks:
                print(f"{b.where()} {b.lang} {b.directives}")
            continue
        if not blocks:
            continue
        work = scratch_for(doc, base, binary)
        env = dict(os.environ, PATH=f"{work / 'bin'}{os.pathsep}{os.environ.get('PATH', '')}")
        for b in blocks:
            name = b.first("file")
            if name is not None:
                (work / name).write_text(b.text, encoding="utf-8")
        for b in blocks:
            reason = b.first("skip")
            if b.first("file") is not None:
                continue
            if reason is not None:
                skipped += 1
                print(f"skip {b.where()}: {reason}", flush=True)
                continue
            ok, message, took = run_block(b, work, env)
            ran += 1
            print(f"{'ok  ' if ok else 'FAIL'} {b.where()} ({took:.1f} s)", flush=True)
            if not ok:
                failures.append(b.where())
                print(f"  block:\n{tail(b.text, 40)}\n  {message}", flush=True)
    if args.list:
        return
    if not args.keep:
        shutil.rmtree(base, ignore_errors=True)
    print(f"doc examples: {ran - len(failures)} of {ran} ran as written, {skipped} skipped "
          f"with their reason, {time.monotonic() - total:.0f} s")
    if failures:
        print("failed: " + ", ".join(failures))
        sys.exit(1)


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Checks every fenced code block of README.md and docs/**/*.md, so the documentation cannot drift
from the library.

Each block's info string says what it is and how it is checked:
  cpp     a complete translation unit: compiled (-fsyntax-only, which instantiates the templates
          it uses) against include/ and the dependencies' include folders.
  python  a complete script: run from the repository root with the built module importable, and
          it must exit 0 within the timeout.
  sh      commands: each script it runs (scripts/..., .ci/run) must exist and be executable, each
          tacmap tool must be built, and every --option given to a tool must appear in that
          tool's --help.
  cmake   CMake for a consumer: every tacmap:: target it names must be one tacmap defines.
  text    output or prose: not checked.
A block without an info string is an error: say what it is.

Usage: check_snippets.py --source-dir DIR --cxx CXX [--include DIR] [--define NAME=VALUE ...]
       [--system-include DIR ...]
       [--python PY]
       [--pythonpath DIR] [--tools-dir DIR] [--jobs N] [FILE.md ...]
"""
from __future__ import annotations

import argparse
import concurrent.futures
import os
import pathlib
import re
import shlex
import subprocess
import sys
import tempfile

FENCE = re.compile(r"^(\s*)(```+|~~~+)\s*([A-Za-z0-9_+-]*)\s*$")
KNOWN = {"cpp", "python", "sh", "cmake", "text"}
TOOLS = ("tacmap-evaluate", "tacmap-calibrate")


class Block:
    def __init__(self, path: pathlib.Path, line: int, lang: str, text: str):
        self.path, self.line, self.lang, self.text = path, line, lang, text

    def where(self) -> str:
        return f"{self.path}:{self.line}"


def blocks_of(path: pathlib.Path) -> list[Block]:
    out: list[Block] = []
    lines = path.read_text(encoding="utf-8").splitlines()
    i = 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        indent, fence, lang = m.group(1), m.group(2), m.group(3).lower()
        start = i + 1
        body: list[str] = []
        i += 1
        while i < len(lines) and not lines[i].strip().startswith(fence[:3]):
            body.append(lines[i][len(indent):] if lines[i].startswith(indent) else lines[i])
            i += 1
        if i >= len(lines):
            raise SystemExit(f"{path}:{start}: a code block is never closed")
        i += 1
        out.append(Block(path, start, lang, "\n".join(body) + "\n"))
    return out


def check_cpp(block: Block, args) -> str | None:
    with tempfile.TemporaryDirectory() as tmp:
        src = pathlib.Path(tmp) / "snippet.cpp"
        src.write_text(block.text, encoding="utf-8")
        cmd = [args.cxx, "-std=c++20", "-fsyntax-only", "-Wall", "-Wextra", "-Werror"]
        cmd += [f"-I{d}" for d in args.include if d] + [f"-D{d}" for d in args.define if d]
        # The compiler's own folders stay out: -isystem /usr/include would break libstdc++'s
        # #include_next.
        cmd += [f"-isystem{d}" for d in args.system_include
                if d and d not in ("/usr/include", "/usr/local/include")] + [str(src)]
        r = subprocess.run(cmd, capture_output=True, text=True)
        if r.returncode != 0:
            return f"does not compile:\n{r.stderr[-4000:]}"
    return None


def check_python(block: Block, args) -> str | None:
    env = dict(os.environ)
    if args.pythonpath:
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [args.pythonpath, env.get("PYTHONPATH")]))
    env["PYTHONDONTWRITEBYTECODE"] = "1"
    env.setdefault("MPLBACKEND", "Agg")
    with tempfile.TemporaryDirectory() as tmp:
        env["TACMAP_SNIPPET_TMP"] = tmp
        try:
            r = subprocess.run([args.python, "-c", block.text], cwd=args.source_dir, env=env,
                               capture_output=True, text=True, timeout=args.timeout)
        except subprocess.TimeoutExpired:
            return f"did not finish within {args.timeout} s"
    if r.returncode != 0:
        return f"exited {r.returncode}:\n{r.stderr[-4000:]}"
    return None


_help_cache: dict[str, str] = {}


def tool_help(tool: pathlib.Path) -> str:
    if str(tool) not in _help_cache:
        r = subprocess.run([str(tool), "--help"], capture_output=True, text=True, timeout=60)
        _help_cache[str(tool)] = r.stdout + r.stderr
    return _help_cache[str(tool)]


def check_sh(block: Block, args) -> str | None:
    problems: list[str] = []
    text = block.text.replace("\\\n", " ")
    for raw in text.splitlines():
        line = raw.split(" #")[0].strip()
        if not line or line.startswith("#"):
            continue
        try:
            words = shlex.split(line, comments=True)
        except ValueError as e:
            problems.append(f"'{raw}': {e}")
            continue
        # Each command of a pipeline or list.
        commands: list[list[str]] = [[]]
        for w in words:
            if w in ("|", "&&", "||", ";"):
                commands.append([])
            else:
                commands[-1].append(w)
        for cmd in commands:
            while cmd and re.match(r"^[A-Za-z_][A-Za-z0-9_]*=", cmd[0]):  # VAR=value prefixes
                cmd = cmd[1:]
            if cmd and cmd[0] in ("sudo", "nice", "time"):
                cmd = cmd[1:]
            if not cmd:
                continue
            prog = cmd[0]
            if prog.startswith(("scripts/", ".ci/", "./scripts/")):
                p = pathlib.Path(args.source_dir) / prog
                if not p.is_file() or not os.access(p, os.X_OK):
                    problems.append(f"'{prog}' is not an executable file of the repository")
            name = pathlib.Path(prog).name
            if name in TOOLS:
                if not args.tools_dir:
                    continue
                tool = pathlib.Path(args.tools_dir) / name
                if not tool.is_file():
                    problems.append(f"{name} is not built in {args.tools_dir}")
                    continue
                usage = tool_help(tool)
                for w in cmd[1:]:
                    opt = w.split("=")[0]
                    if opt.startswith("--") and opt != "--help" and opt not in usage:
                        problems.append(f"{name} has no option {opt} (not in its --help)")
    return "\n".join(problems) if problems else None


def defined_targets(source_dir: pathlib.Path) -> set[str]:
    names: set[str] = set()
    for f in list(source_dir.glob("CMakeLists.txt")) + list(source_dir.glob("cmake/*")) + list(
            source_dir.glob("src/CMakeLists.txt")):
        if f.is_file():
            names.update(re.findall(r"tacmap::[A-Za-z0-9_]+", f.read_text(encoding="utf-8")))
    return names


def check_cmake(block: Block, args) -> str | None:
    known = defined_targets(pathlib.Path(args.source_dir))
    used = set(re.findall(r"tacmap::[A-Za-z0-9_]+", block.text))
    missing = sorted(used - known)
    if missing:
        return f"names targets tacmap does not define: {', '.join(missing)}"
    return None


CHECKS = {"cpp": check_cpp, "python": check_python, "sh": check_sh, "cmake": check_cmake}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--source-dir", required=True)
    ap.add_argument("--cxx", default="c++")
    ap.add_argument("--include", action="append", default=[], help="tacmap's include folder")
    ap.add_argument("--define", action="append", default=[],
                    help="NAME=VALUE for the C++ blocks (e.g. TACMAP_PRECOMPILED=1: compiled as a "
                         "consumer of tacmap::precompiled sees the headers)")
    ap.add_argument("--system-include", action="append", default=[],
                    help="a dependency's include folder (its warnings are not ours)")
    ap.add_argument("--python", default=sys.executable)
    ap.add_argument("--pythonpath", default="")
    ap.add_argument("--tools-dir", default="")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--timeout", type=int, default=300)
    ap.add_argument("--only", choices=sorted(CHECKS), help="check only blocks of this kind")
    ap.add_argument("files", nargs="*")
    args = ap.parse_args()
    root = pathlib.Path(args.source_dir)
    files = [pathlib.Path(f) for f in args.files if f] or (
        [root / "README.md"] + sorted((root / "docs").rglob("*.md")))
    blocks: list[Block] = []
    errors: list[str] = []
    for f in files:
        for b in blocks_of(f):
            rel = b.path.relative_to(root) if b.path.is_absolute() else b.path
            b.path = rel
            if b.lang not in KNOWN:
                errors.append(f"{b.where()}: a code block tagged '{b.lang or '(nothing)'}'; "
                              f"expected one of {', '.join(sorted(KNOWN))}")
                continue
            if b.lang in CHECKS and (args.only is None or args.only == b.lang):
                blocks.append(b)
    counts: dict[str, int] = {}
    for b in blocks:
        counts[b.lang] = counts.get(b.lang, 0) + 1
    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        results = list(pool.map(lambda b: (b, CHECKS[b.lang](b, args)), blocks))
    for b, problem in results:
        if problem:
            errors.append(f"{b.where()}: {b.lang} block {problem}")
    summary = ", ".join(f"{n} {k}" for k, n in sorted(counts.items()))
    print(f"check_snippets: {len(files)} files, {len(blocks)} blocks checked ({summary})")
    for e in errors:
        print(f"FAIL {e}", file=sys.stderr)
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())

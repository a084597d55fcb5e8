#!/usr/bin/python3
"""The command-line contract of every Python program in tools/ (the C++ programs' rule,
examples/common/cli.hpp): --help prints to stdout and exits 0; --version prints exactly
"<file name> shadowsense <major>.<minor>.<patch>" and exits 0, the numbers being the
SHADOWSENSE_VERSION_* macros of include/shadowsense/core/version.hpp; an unknown option exits 2
with the program's name on stderr and nothing on stdout. None of the three writes a file (each
runs in an empty folder, which must stay empty, and no file under tests/data/ may change).

A program is a tools/**/*.py other than test_*.py with an `if __name__ == "__main__":` block;
any other .py must be listed in MODULES, so a new script without that block fails here.
Also checks that tools/ss_version.py outside the repository reports "unknown" without failing.

Each program gets an interpreter of its own (in an empty working folder) that runs it with each
option in turn; see harness().

usage: python_tools_cli_test.py REPO_ROOT   (exit 0: all passed; 1: failures listed on stderr)
"""
import concurrent.futures
import contextlib
import io
import json
import os
import re
import runpy
import shutil
import subprocess
import sys
import tempfile
import time
import traceback

MODULES = {"ss_version.py", "atomic_write.py", "model_header.py", "handsets/handsil.py",
           "realhand/timeline_io.py"}  # imported by the programs, not run
OPTIONS = ("--help", "--version", "--no-such-option-xyz")


def header_version(root):
    path = os.path.join(root, "include", "shadowsense", "core", "version.hpp")
    with open(path) as f:
        text = f.read()
    nums = [re.search(rf"#define SHADOWSENSE_VERSION_{k}\s+(\d+)", text) for k in
            ("MAJOR", "MINOR", "PATCH")]
    if not all(nums):
        raise SystemExit(f"{path}: no SHADOWSENSE_VERSION_MAJOR/MINOR/PATCH")
    return ".".join(m.group(1) for m in nums)


def find_programs(tools):
    programs, errors = [], []
    for d, dirs, files in os.walk(tools):
        dirs[:] = sorted(x for x in dirs if x != "__pycache__")
        for name in sorted(files):
            if not name.endswith(".py") or name.startswith("test_"):
                continue
            rel = os.path.relpath(os.path.join(d, name), tools).replace(os.sep, "/")
            with open(os.path.join(d, name), encoding="utf-8") as f:
                is_program = re.search(r'^if __name__ == "__main__":', f.read(), re.M)
            if is_program:
                programs.append(rel)
            elif rel not in MODULES:
                errors.append(f"tools/{rel}: no `if __name__ == \"__main__\":` block and not "
                              "in MODULES of this test")
    for rel in MODULES:
        if not os.path.isfile(os.path.join(tools, rel)):
            errors.append(f"tools/{rel}: listed in MODULES but missing")
    return programs, errors


def snapshot(folder):
    out = {}
    for d, _, files in os.walk(folder):
        for name in files:
            st = os.stat(os.path.join(d, name))
            out[os.path.join(d, name)] = (st.st_size, st.st_mtime_ns)
    return out


def harness(path):
    """Runs the program at `path` once per option in this process, as the interpreter would
    (run as __main__, SystemExit -> exit status, an uncaught exception -> traceback and 1), and
    prints one JSON list of [option, status, stdout, stderr]. One process per program rather
    than per option: torch is then imported once, not three times."""
    sys.path[0] = os.path.dirname(os.path.abspath(path))  # as `python3 PATH` would have it
    results = []
    for option in OPTIONS:
        out, err = io.StringIO(), io.StringIO()
        sys.argv = [path, option]
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                runpy.run_path(path, run_name="__main__")
                status = 0
            except SystemExit as e:
                if e.code is None or isinstance(e.code, int):
                    status = e.code or 0
                else:
                    print(e.code, file=sys.stderr)
                    status = 1
            except BaseException:  # what the interpreter does with an uncaught exception
                traceback.print_exc()
                status = 1
        results.append([option, status, out.getvalue(), err.getvalue()])
    sys.__stdout__.write(json.dumps(results))
    return 0


def run(tools, rel, env):
    """One program under harness() in an empty folder: ([(option, Result)], files it left in
    the folder, seconds)."""
    with tempfile.TemporaryDirectory(prefix="ss_cli_") as cwd:
        t0 = time.monotonic()
        r = subprocess.run([sys.executable, os.path.abspath(__file__), "--harness",
                            os.path.join(tools, rel)], cwd=cwd, env=env, capture_output=True,
                           text=True, timeout=120)
        seconds = time.monotonic() - t0
        left = sorted(os.listdir(cwd))
    if r.returncode != 0:
        raise RuntimeError(f"the harness failed (exit {r.returncode}): {r.stderr.strip()}")
    return [(o, Result(status, out, err)) for o, status, out, err in json.loads(r.stdout)], \
        left, seconds


class Result:
    def __init__(self, returncode, stdout, stderr):
        self.returncode, self.stdout, self.stderr = returncode, stdout, stderr


def check(rel, option, r, version):
    name = os.path.basename(rel)
    what = f"tools/{rel} {option}"
    errs = []
    if option == "--help":
        if r.returncode != 0:
            errs.append(f"{what}: exit {r.returncode}, expected 0; stderr: {r.stderr.strip()}")
        if not r.stdout.strip():
            errs.append(f"{what}: nothing on stdout")
        elif "--version" not in r.stdout:
            errs.append(f"{what}: the help does not mention --version")
        if r.stderr:
            errs.append(f"{what}: wrote to stderr: {r.stderr.strip()}")
    elif option == "--version":
        expected = f"{name} shadowsense {version}\n"
        if r.returncode != 0:
            errs.append(f"{what}: exit {r.returncode}, expected 0; stderr: {r.stderr.strip()}")
        if r.stdout != expected:
            errs.append(f"{what}: printed {r.stdout!r}, expected {expected!r}")
        if r.stderr:
            errs.append(f"{what}: wrote to stderr: {r.stderr.strip()}")
    else:
        if r.returncode != 2:
            errs.append(f"{what}: exit {r.returncode}, expected 2; stderr: {r.stderr.strip()}")
        if r.stdout:
            errs.append(f"{what}: wrote to stdout: {r.stdout.strip()}")
        if name not in r.stderr:
            errs.append(f"{what}: stderr does not name the program: {r.stderr.strip()!r}")
        if "Traceback" in r.stderr:
            errs.append(f"{what}: a traceback: {r.stderr.strip()}")
    return errs


def check_unknown_version(tools):
    """ss_version.py away from the repository: "unknown", no exception."""
    with tempfile.TemporaryDirectory(prefix="ss_cli_") as d:
        os.makedirs(os.path.join(d, "tools"))
        shutil.copy(os.path.join(tools, "ss_version.py"), os.path.join(d, "tools"))
        r = subprocess.run([sys.executable, "-c",
                            "import ss_version; print(ss_version.line('x.py'))"],
                           cwd=os.path.join(d, "tools"), capture_output=True, text=True,
                           timeout=60)
    if r.returncode != 0 or r.stdout != "x.py shadowsense unknown\n":
        return [f"ss_version.py without the header: exit {r.returncode}, printed "
                f"{r.stdout!r}, expected 'x.py shadowsense unknown'; stderr: {r.stderr}"]
    return []


def main(argv):
    if len(argv) == 3 and argv[1] == "--harness":
        return harness(argv[2])
    if len(argv) != 2 or argv[1].startswith("-"):
        print(__doc__.strip(), file=sys.stderr)
        return 2
    root = os.path.abspath(argv[1])
    tools = os.path.join(root, "tools")
    version = header_version(root)
    programs, errors = find_programs(tools)
    if not programs:
        errors.append(f"{tools}: no programs found")
    env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1")
    data = os.path.join(root, "tests", "data")
    before = snapshot(data)
    t0 = time.monotonic()
    slowest = (0.0, "")
    # Two programs at a time: most of the time is the interpreter importing torch or cv2.
    with concurrent.futures.ThreadPoolExecutor(max_workers=2) as pool:
        futures = {rel: pool.submit(run, tools, rel, env) for rel in programs}
        for rel, fut in futures.items():
            try:
                results, left, seconds = fut.result()
            except (subprocess.TimeoutExpired, RuntimeError) as e:
                errors.append(f"tools/{rel}: {e}")
                continue
            slowest = max(slowest, (seconds, rel))
            if [o for o, _ in results] != list(OPTIONS):
                errors.append(f"tools/{rel}: the harness ran {[o for o, _ in results]}")
            if left:
                errors.append(f"tools/{rel} {' / '.join(OPTIONS)}: wrote {left} into the "
                              "working folder")
            for option, r in results:
                errors += check(rel, option, r, version)
    errors += check_unknown_version(tools)
    after = snapshot(data)
    changed = sorted(p for p in set(before) | set(after) if before.get(p) != after.get(p))
    if changed:
        errors.append(f"files under tests/data changed while the programs ran: {changed}")
    print(f"{len(programs)} programs x {len(OPTIONS)} options in {time.monotonic() - t0:.1f} s "
          f"(slowest: tools/{slowest[1]}, {slowest[0]:.1f} s), version {version}")
    for e in errors:
        print(e, file=sys.stderr)
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))

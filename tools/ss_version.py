"""The shadowsense version for the --version of the Python tools (the C++ programs print
shadowsense::version_string, examples/common/cli.hpp).

version() -> the `version_string` of include/shadowsense/core/version.hpp, found relative to
    this file (tools/ss_version.py); "unknown" when the header is missing or has no
    version_string (a copy of the tools outside the repository). Never raises.
line(prog) -> "<prog> shadowsense <version>" (as the C++ programs print it), the line --version prints.

Scripts in tools/ import it directly; scripts in tools/<sub>/ put tools/ on sys.path first:
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    import ss_version  # noqa: E402
    ap.add_argument("--version", action="version", version=ss_version.line(ap.prog))
Stateless apart from reading the header; safe from any thread.
"""
import os
import re

HEADER = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "include", "shadowsense",
                      "core", "version.hpp")


def version(header=HEADER):
    try:
        with open(header, encoding="utf-8", errors="replace") as f:
            text = f.read()
    except OSError:
        return "unknown"
    m = re.search(r'\bversion_string\s*=\s*"([^"\s]+)"', text)
    return m.group(1) if m else "unknown"


def line(prog):
    return f"{prog} shadowsense {version()}"

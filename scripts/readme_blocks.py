#!/usr/bin/python3
"""Runs the README's command blocks as a user pastes them into a fresh shell, and fails if any fails.

A fenced block right after a marker line `<!-- readme-test: SESSION [expect="TEXT"]... -->` in
README.md belongs to SESSION. The blocks of one session run in README order in one `bash` (as one
terminal), with `set -e -o pipefail`, from the repository root, with a private ROS master port
(ROS_MASTER_URI on a free port: the blocks' `roslaunch` starts its master there) and a temporary
ROS_HOME; sessions run one after another, and everything a session left running is stopped after
it. A session passes when its shell exits 0 within the time limit, its output holds every expected
TEXT, and none of the failure texts below. The blocks are taken from the README itself: there is no
second copy to drift.

Without SESSION arguments it also checks that every relative link of README.md and docs/*.md names
a file of the repository.

Usage: scripts/readme_blocks.py [--devel DIR] [--junit FILE] [--list] [SESSION...]
  --devel DIR   the devel space the blocks' `source devel/setup.bash` means (default: devel)
  --junit FILE  also write the results as JUnit XML (one test case per session)
"""
import argparse
import os
import re
import signal
import socket
import subprocess
import sys
import tempfile
import time
from xml.sax.saxutils import escape, quoteattr

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MARKER = re.compile(r"<!--\s*readme-test:\s*(\S+)(.*?)-->")
EXPECT = re.compile(r'expect="([^"]*)"')
# Output that means a command failed even where its exit status does not say so.
FAILURES = ["success: False", "Cannot load message class", "Traceback (most recent call last)",
            "ERROR: ", "[rosrun] Couldn't find", "Unable to communicate with master"]
TIME_LIMIT = 180.0  # [s] per session


def extract(readme):
    """{session: [(line number, block text, [expected texts])]} in README order."""
    lines = open(readme, encoding="utf-8").read().splitlines()
    sessions = {}
    i = 0
    while i < len(lines):
        match = MARKER.search(lines[i])
        if match:
            start = i + 1
            while start < len(lines) and not lines[start].startswith("```"):
                start += 1
            end = start + 1
            while end < len(lines) and not lines[end].startswith("```"):
                end += 1
            if end >= len(lines):
                sys.exit("readme_blocks: README.md:%d: marker without a fenced block" % (i + 1))
            block = "\n".join(lines[start + 1:end])
            sessions.setdefault(match.group(1), []).append(
                (i + 1, block, EXPECT.findall(match.group(2))))
            i = end
        i += 1
    return sessions


LINK = re.compile(r"\]\(([^)#\s]+)(?:#[^)]*)?\)")


def broken_links():
    """Relative links of README.md and docs/*.md whose target does not exist in the repository."""
    pages = ["README.md"] + sorted(os.path.join("docs", name) for name in
                                   os.listdir(os.path.join(REPO, "docs")) if name.endswith(".md"))
    broken = []
    for page in pages:
        text = open(os.path.join(REPO, page), encoding="utf-8").read()
        for target in LINK.findall(text):
            if "://" in target:
                continue
            path = os.path.normpath(os.path.join(REPO, os.path.dirname(page), target))
            if not os.path.exists(path):
                broken.append("%s: %s" % (page, target))
    return broken


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def stop_group(pid):
    """Stops everything the session left running (its process group): TERM, then KILL."""
    for sig, wait in ((signal.SIGTERM, 15.0), (signal.SIGKILL, 5.0)):
        try:
            os.killpg(pid, sig)
        except ProcessLookupError:
            return
        deadline = time.time() + wait
        while time.time() < deadline:
            try:
                os.killpg(pid, 0)
            except ProcessLookupError:
                return
            time.sleep(0.1)


def run_session(name, blocks, devel):
    home = tempfile.mkdtemp(prefix="readme_%s." % name)
    env = dict(os.environ, ROS_MASTER_URI="http://127.0.0.1:%d" % free_port(),
               ROS_HOSTNAME="127.0.0.1", ROS_HOME=home, ROS_LOG_DIR=os.path.join(home, "log"))
    script = "set -e -o pipefail\n"
    for line, block, _ in blocks:
        if devel != os.path.join(REPO, "devel"):
            block = block.replace("source devel/setup.bash", "source %s/setup.bash" % devel)
        script += "# README.md:%d\n%s\n" % (line, block)
    log_path = os.path.join(home, "session.log")
    start = time.time()
    with open(log_path, "w") as log:
        process = subprocess.Popen(["bash", "-c", script], cwd=REPO, env=env, stdout=log,
                                   stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                   start_new_session=True)
        try:
            status = process.wait(timeout=TIME_LIMIT)
        except subprocess.TimeoutExpired:
            status = "timed out after %.0f s" % TIME_LIMIT
        stop_group(process.pid)
    seconds = time.time() - start
    output = open(log_path, encoding="utf-8", errors="replace").read()
    problems = []
    if status != 0:
        problems.append("the shell exited with %s" % status)
    for _, _, expected in blocks:
        problems += ["missing in the output: %r" % text for text in expected if text not in output]
    problems += ["the output has %r" % text for text in FAILURES if text in output]
    return problems, seconds, output


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--devel", default=os.path.join(REPO, "devel"))
    parser.add_argument("--junit")
    parser.add_argument("--list", action="store_true")
    parser.add_argument("sessions", nargs="*")
    args = parser.parse_args()
    devel = os.path.abspath(args.devel)
    if os.environ.get("CR_README_BLOCKS") == "skip":  # scripts/sanitize.sh: see there
        print("readme: skipped (CR_README_BLOCKS=skip)")
        if args.junit:
            os.makedirs(os.path.dirname(os.path.abspath(args.junit)), exist_ok=True)
            with open(args.junit, "w") as out:
                out.write('<?xml version="1.0" encoding="UTF-8"?>\n<testsuite name="ReadmeBlocks" '
                          'tests="1" failures="0" errors="0" skipped="1">\n  <testcase '
                          'classname="ReadmeBlocks" name="all"><skipped/></testcase>\n'
                          '</testsuite>\n')
        return 0
    sessions = extract(os.path.join(REPO, "README.md"))
    if args.list:
        for name, blocks in sessions.items():
            print("%s: README.md lines %s" % (name, ", ".join(str(b[0]) for b in blocks)))
        return 0
    names = args.sessions or list(sessions)
    unknown = [n for n in names if n not in sessions]
    if unknown:
        sys.exit("readme_blocks: no such session in README.md: %s" % ", ".join(unknown))
    cases = []
    if not args.sessions:  # every link of the README and docs/ names a file of the repository
        start = time.time()
        broken = broken_links()
        print("readme: links: %s" % ("FAILED" if broken else "ok"))
        for link in broken:
            print("  no such file: " + link)
        cases.append(("links", time.time() - start, ["no such file: " + b for b in broken], ""))
    for name in names:
        problems, seconds, output = run_session(name, sessions[name], devel)
        print("readme: %s: %s in %.1f s" % (name, "FAILED" if problems else "ok", seconds))
        if problems:
            print("\n".join("  " + p for p in problems))
            print("  output:\n" + "\n".join("    " + l for l in output.splitlines()[-60:]))
        cases.append((name, seconds, problems, output))
    failed = sum(1 for c in cases if c[2])
    if args.junit:
        os.makedirs(os.path.dirname(os.path.abspath(args.junit)), exist_ok=True)
        with open(args.junit, "w") as out:
            out.write('<?xml version="1.0" encoding="UTF-8"?>\n')
            out.write('<testsuite name="ReadmeBlocks" tests="%d" failures="%d" errors="0">\n'
                      % (len(cases), failed))
            for name, seconds, problems, output in cases:
                out.write('  <testcase classname="ReadmeBlocks" name=%s time="%.1f">\n'
                          % (quoteattr(name), seconds))
                if problems:
                    out.write('    <failure message=%s>%s</failure>\n'
                              % (quoteattr("; ".join(problems)), escape(output[-20000:])))
                out.write("  </testcase>\n")
            out.write("</testsuite>\n")
    print("readme: %d sessions, %d failed" % (len(cases), failed))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

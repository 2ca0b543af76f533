#!/usr/bin/python3
"""Runs the README's command blocks as a user pastes them into a fresh shell, and fails if any fails.

A fenced block right after a marker line `<!-- readme-test: SESSION [expect="TEXT"]...
[value="PATH = NUMBER [+- TOLERANCE]"]... -->` in README.md belongs to SESSION. The blocks of one
session run in README order in one `bash` (one terminal, top to bottom), with `set -e -o
pipefail`, from the repository root, in the environment of a fresh login shell: HOME, USER, LANG
and TERM kept, Debian's default PATH, nothing of ROS (no ROS_HOSTNAME, ROS_IP, no sourced setup
file). Two variables are set that a fresh shell lacks, and neither changes what the blocks do:
ROS_MASTER_URI on a free port (the blocks' `roslaunch` starts its master there, as it would on
11311; the machine may run other ROS systems and tests meanwhile) and a temporary ROS_HOME for the
logs. Sessions run one after another.

A session passes when its shell exits 0 within the time limit, its output holds every expected
TEXT and none of the failure texts below, every value check holds, and nothing it started is left
running when its shell has exited (the README's blocks stop what they start; whatever is left is
then stopped and named). A value check reads the YAML answer of the block's last `rosservice call`
(from its `success:` line on; log lines of background nodes are skipped): PATH names a field
(`bodies[1].twist.linear.x`; `impulses[*].sticking` every element; `len(detected_contacts)` a
length), and a number must lie within TOLERANCE of NUMBER, by default half a unit of its last
digit (the README's rounded number is the answer rounded); True, False or a word must be equal.
The blocks are taken from the README itself: there is no second copy to drift.

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

import yaml

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MARKER = re.compile(r"<!--\s*readme-test:\s*(\S+)(.*?)-->")
EXPECT = re.compile(r'expect="([^"]*)"')
VALUE = re.compile(r'value="([^"]*)"')
# Output that means a command failed even where its exit status does not say so.
FAILURES = ["success: False", "Cannot load message class", "Traceback (most recent call last)",
            "ERROR: ", "[rosrun] Couldn't find", "Unable to communicate with master"]
TIME_LIMIT = 300.0  # [s] per session
# A fresh login shell's environment: these are kept, PATH is Debian's default, nothing else.
KEPT = ("HOME", "USER", "LOGNAME", "LANG", "LC_ALL", "TERM", "SHELL", "TMPDIR")
DEFAULT_PATH = "/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin"
# Printed between blocks (an echo, nothing set) so that each block's output can be found.
SEPARATOR = "@@readme-test: README.md:%d@@"


def extract(readme):
    """{session: [(line number, block text, [expected texts], [value checks])]} in README order."""
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
                (i + 1, block, EXPECT.findall(match.group(2)), VALUE.findall(match.group(2))))
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


CHECK = re.compile(r"^\s*(len\()?([A-Za-z_][\w.\[\]*]*)\)?\s*=\s*(\S+)(?:\s*\+-\s*(\S+))?\s*$")
STEP = re.compile(r"([A-Za-z_]\w*)|\[(\d+|\*)\]|\.")
ANSWER_LINE = re.compile(r"^(\s|-|[a-z_]\w*:(\s|$))")


def last_answer(output):
    """The YAML answer of the last `rosservice call` in a block's output, or None: the lines from its
    last `success:` line on that are YAML (indented, list items or `key:` lines); lines of nodes
    running in the background (`[ INFO] ...`, `process[...]`) are skipped."""
    lines = output.splitlines()
    starts = [i for i, line in enumerate(lines) if re.match(r"^success: (True|False)\s*$", line)]
    if not starts:
        return None
    text = "\n".join(line for line in lines[starts[-1]:] if ANSWER_LINE.match(line))
    return yaml.safe_load(text)


def resolve(answer, path):
    """The values PATH names in ANSWER (several where it has [*]); raises KeyError/IndexError."""
    values = [answer]
    for name, index in STEP.findall(path):
        if name:
            values = [v[name] for v in values]
        elif index == "*":
            values = [item for v in values for item in v]
        elif index:
            values = [v[int(index)] for v in values]
    return values


def number(text):
    try:
        return float(text)
    except (TypeError, ValueError):
        return None


def check_values(answer, checks):
    """Problems of the value checks (`PATH = NUMBER [+- TOLERANCE]`) against ANSWER."""
    problems = []
    for check in checks:
        match = CHECK.match(check)
        if not match:
            problems.append("value check %r: not PATH = VALUE [+- TOLERANCE]" % check)
            continue
        length, path, want, tolerance = match.groups()
        if answer is None:
            problems.append("value check %r: the block printed no answer" % check)
            continue
        try:
            got = resolve(answer, path)
        except (KeyError, IndexError, TypeError) as error:
            problems.append("value check %r: the answer has no %s (%s)" % (check, path, error))
            continue
        if length:
            got = [len(v) for v in got]
        wanted = number(want)
        if wanted is not None and tolerance is None:  # half a unit of the last digit shown
            digits = len(want.split(".")[1]) if "." in want else 0
            tolerance = 0.5 * 10.0 ** -digits
        if not got:
            problems.append("value check %r: %s is empty" % (check, path))
        for value in got:
            if wanted is None:
                ok = str(value) == want
            else:
                got_number = number(value)
                ok = got_number is not None and (got_number == wanted or abs(
                    got_number - wanted) <= float(tolerance) * (1 + 1e-12))
            if not ok:
                problems.append("value check %r: the answer has %s = %r" % (check, path, value))
    return problems


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


def session_processes(master_uri):
    """{pid: command line} of the processes started with this session's ROS_MASTER_URI (the
    blocks' background jobs, the nodes roslaunch started in sessions of their own, the master)."""
    mark = ("ROS_MASTER_URI=%s\0" % master_uri).encode()
    found = {}
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            with open("/proc/%s/environ" % pid, "rb") as f:
                if mark not in f.read():
                    continue
            with open("/proc/%s/cmdline" % pid, "rb") as f:
                found[int(pid)] = f.read().replace(b"\0", b" ").decode(errors="replace").strip()
        except OSError:
            continue
    return found


def stop_processes(pids):
    for sig, wait in ((signal.SIGTERM, 10.0), (signal.SIGKILL, 5.0)):
        for pid in pids:
            try:
                os.kill(pid, sig)
            except ProcessLookupError:
                pass
        deadline = time.time() + wait
        while time.time() < deadline and any(os.path.exists("/proc/%d" % p) for p in pids):
            time.sleep(0.1)


def fresh_shell_environment(master_uri, home):
    env = {key: os.environ[key] for key in KEPT if key in os.environ}
    env.update(PATH=DEFAULT_PATH, ROS_MASTER_URI=master_uri, ROS_HOME=home,
               ROS_LOG_DIR=os.path.join(home, "log"))
    return env


def run_session(name, blocks, devel):
    home = tempfile.mkdtemp(prefix="readme_%s." % name)
    master_uri = "http://localhost:%d" % free_port()
    script = "set -e -o pipefail\n"
    for line, block, _, _ in blocks:
        if devel != os.path.join(REPO, "devel"):
            block = block.replace("source devel/setup.bash", "source %s/setup.bash" % devel)
        script += "echo '%s'\n# README.md:%d\n%s\n" % (SEPARATOR % line, line, block)
    log_path = os.path.join(home, "session.log")
    start = time.time()
    with open(log_path, "w") as log:
        process = subprocess.Popen(["bash", "-c", script], cwd=REPO,
                                   env=fresh_shell_environment(master_uri, home), stdout=log,
                                   stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                   start_new_session=True)
        try:
            status = process.wait(timeout=TIME_LIMIT)
        except subprocess.TimeoutExpired:
            status = "timed out after %.0f s" % TIME_LIMIT
        left = {}
        deadline = time.time() + 5.0  # what was stopped may take a moment to exit
        while time.time() < deadline:
            left = session_processes(master_uri)
            if not left:
                break
            time.sleep(0.2)
        stop_group(process.pid)
        stop_processes(list(left))
    seconds = time.time() - start
    output = open(log_path, encoding="utf-8", errors="replace").read()
    problems = []
    if status != 0:
        problems.append("the shell exited with %s" % status)
    if status == 0:  # after a failure, what the last blocks would have stopped is still running
        problems += ["left running after the last block: %s" % command
                     for command in sorted(left.values())]
    for line, _, expected, checks in blocks:
        problems += ["missing in the output: %r" % text for text in expected if text not in output]
        if checks:
            mine = output.partition(SEPARATOR % line + "\n")[2]
            mine = re.split(re.escape(SEPARATOR).replace("%d", r"\d+"), mine)[0]
            try:
                answer = last_answer(mine)
            except yaml.YAMLError as error:
                problems.append("README.md:%d: its answer does not parse as YAML: %s" % (line, error))
                continue
            problems += ["README.md:%d: %s" % (line, p) for p in check_values(answer, checks)]
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

#!/usr/bin/python3
"""Counts the test cases in a directory of JUnit XML result files (gtest, rostest, rosunit, ours).

Usage: scripts/count_test_results.py RESULTS_DIR
Prints `N passed, N failed, N skipped` from the <testcase> elements themselves: catkin_test_results
adds the `tests` attributes of both <testsuites> and <testsuite>, which counts every gtest case
twice. A case is failed if it holds a <failure> or <error>, skipped if it holds <skipped> or gtest
reports it not run (status="notrun"). A result file that cannot be parsed counts as one failure.
Exits 1 if any case failed, 2 if there is no case at all.
"""
import os
import sys
import xml.etree.ElementTree as ElementTree


def count(directory):
    passed = failed = skipped = 0
    broken = []
    for root, _, files in os.walk(directory):
        for name in sorted(files):
            if not name.endswith(".xml"):
                continue
            path = os.path.join(root, name)
            try:
                tree = ElementTree.parse(path)
            except ElementTree.ParseError as error:
                broken.append("%s: %s" % (path, error))
                continue
            for case in tree.iter("testcase"):
                if case.find("failure") is not None or case.find("error") is not None:
                    failed += 1
                elif case.find("skipped") is not None or case.get("status") == "notrun":
                    skipped += 1
                else:
                    passed += 1
    return passed, failed + len(broken), skipped, broken


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    passed, failed, skipped, broken = count(sys.argv[1])
    for line in broken:
        print("unreadable result file: " + line)
    print("%d passed, %d failed, %d skipped" % (passed, failed, skipped))
    if failed:
        return 1
    return 2 if passed + skipped == 0 else 0


if __name__ == "__main__":
    sys.exit(main())

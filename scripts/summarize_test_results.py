#!/usr/bin/env python3
"""Counts the JUnit results that catkin wrote and prints 'N passed, N failed[, N skipped]'.

A test binary that crashed leaves a result file with a failure (catkin writes one for a
missing result), so crashes count as failures. A failed build or lint adds one failure each.
"""
import glob
import os
import sys
import xml.etree.ElementTree as ET


def main():
    results_dir, build_status, lint_failed = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    passed = failed = skipped = 0
    failures = []
    for path in sorted(glob.glob(os.path.join(results_dir, "**", "*.xml"), recursive=True)):
        try:
            root = ET.parse(path).getroot()
        except ET.ParseError as err:
            failed += 1
            failures.append(f"{path}: unreadable result ({err})")
            continue
        for case in root.iter("testcase"):
            name = f"{case.get('classname')}.{case.get('name')}"
            if case.find("failure") is not None or case.find("error") is not None:
                failed += 1
                failures.append(name)
            elif case.find("skipped") is not None or case.get("status") == "notrun":
                skipped += 1
            else:
                passed += 1
    if build_status != 0:
        failed += 1
        failures.append(f"catkin_make run_tests exited with {build_status}")
    if lint_failed:
        failed += 1
        failures.append("catkin_lint")
    if passed + failed == 0:
        failed += 1
        failures.append("no test result found")
    for name in failures:
        print(f"FAILED: {name}")
    line = f"{passed} passed, {failed} failed"
    if skipped:
        line += f", {skipped} skipped"
    print(line)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

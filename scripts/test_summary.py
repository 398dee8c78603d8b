#!/usr/bin/env python3
"""Counts passed/failed/skipped test cases in the JUnit XML files of a catkin test_results dir.
Prints the failed cases and one summary line; exits non-zero when anything failed or nothing ran."""
import glob
import os
import sys
import xml.etree.ElementTree as ET

root = sys.argv[1]
passed, failed, skipped, broken = 0, [], 0, []
for path in sorted(glob.glob(os.path.join(root, "**", "*.xml"), recursive=True)):
    try:
        tree = ET.parse(path)
    except ET.ParseError as e:
        broken.append(f"{path}: {e}")
        continue
    cases = list(tree.getroot().iter("testcase"))
    if not cases:
        broken.append(f"{path}: no test cases (the test binary crashed or did not start)")
    for case in cases:
        name = f"{case.get('classname')}.{case.get('name')}"
        if case.find("failure") is not None or case.find("error") is not None:
            failed.append(name)
        elif case.find("skipped") is not None or case.get("result") == "skipped":
            skipped += 1
        else:
            passed += 1
for f in failed:
    print(f"[test] FAILED {f}")
for b in broken:
    print(f"[test] BROKEN {b}")
print(f"[test] {passed} passed, {len(failed) + len(broken)} failed, {skipped} skipped")
sys.exit(1 if failed or broken or passed + skipped == 0 else 0)

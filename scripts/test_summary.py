#!/usr/bin/env python3
"""Counts passed/failed/skipped test cases in the JUnit XML files of a catkin test_results dir.
Prints the failed cases with the end of their message and one summary line; exits non-zero when
anything failed or nothing ran."""
import glob
import os
import sys
import xml.etree.ElementTree as ET


def why(element):
    """The failure's message, its last lines kept (the assertion), at most 600 characters."""
    text = (element.get("message") or "") + "\n" + (element.text or "")
    lines = [ln.rstrip() for ln in text.splitlines() if ln.strip()]
    return "\n".join("    " + ln for ln in lines[-6:])[-600:]


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
        bad = case.find("failure")
        bad = bad if bad is not None else case.find("error")
        if bad is not None:
            failed.append((name, why(bad)))
        elif case.find("skipped") is not None or case.get("result") == "skipped":
            skipped += 1
        else:
            passed += 1
for name, message in failed:
    print(f"[test] FAILED {name}")
    if message:
        print(message)
for b in broken:
    print(f"[test] BROKEN {b}")
print(f"[test] {passed} passed, {len(failed) + len(broken)} failed, {skipped} skipped")
sys.exit(1 if failed or broken or passed + skipped == 0 else 0)

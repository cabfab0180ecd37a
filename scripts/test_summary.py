#!/usr/bin/env python3
"""Totals over the gtest and rostest result files of a catkin test run.

catkin writes, per gtest binary, gtest-<name>.xml; per rostest, rostest-<name>.xml holds one
case per test node (did it run and pass), and the test node's own cases are in
rosunit-<test-name>.xml. Counted: the gtest cases, the test nodes' own cases, and a rostest
wrapper case only when it failed (a node that died or never started leaves no inner cases), and
the cases of scripts/test.sh's own checks, check-<name>.xml (the arm64 cross-compile, the deps check). A
binary that crashed or never wrote results leaves MISSING-*.xml, counted as one failure. Prints the failed cases, then one line
'N passed, N failed' (', N skipped' when some were skipped); exits 1 on any failure or when no
test ran.
"""
import glob
import os
import sys
import xml.etree.ElementTree as ET


def skip_reason(root):
    """rosunit records a Python test's skipTest as a pass; such tests print a line 'SKIPPED:
    reason' (test/distributed_check.py), which is taken here as the skip it is."""
    for out in root.iter('system-out'):
        for line in (out.text or '').splitlines():
            line = line.strip().replace('<![CDATA[', '')
            if line.startswith('SKIPPED:'):
                return line[len('SKIPPED:'):].strip()
    return None


def cases(path):
    root = ET.parse(path).getroot()
    skipped_because = skip_reason(root)
    for tc in root.iter('testcase'):
        name = '%s.%s' % (tc.get('classname', ''), tc.get('name', ''))
        if tc.find('failure') is not None or tc.find('error') is not None:
            node = tc.find('failure') if tc.find('failure') is not None else tc.find('error')
            msg = (node.get('message') or node.text or '').strip().splitlines()
            yield name, 'failed', msg[0] if msg else ''
        elif tc.find('skipped') is not None or tc.get('result') == 'skipped' \
                or tc.get('status') == 'notrun':
            yield name, 'skipped', ''
        elif skipped_because:
            yield name, 'skipped', skipped_because
        else:
            yield name, 'passed', ''


def main():
    if len(sys.argv) > 1:
        results = sys.argv[1]
    else:  # the workspace of scripts/build.sh: $SE3_SIM_WS, else beside the clone
        repo = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
        ws = os.environ.get('SE3_SIM_WS') or os.path.join(
            os.path.dirname(repo), os.path.basename(repo) + '_ws')
        results = os.path.join(ws, 'build', 'test_results')
    passed = failed = skipped = 0
    files = sorted(glob.glob(os.path.join(results, '**', '*.xml'), recursive=True))
    for f in files:
        base = os.path.basename(f)
        if base.startswith('MISSING'):
            failed += 1
            print('FAILED  %s (no results: the test crashed or did not run)' % base)
            continue
        if not (base.startswith('gtest-') or base.startswith('rostest-')
                or base.startswith('rosunit-') or base.startswith('check-')):
            continue
        wrapper = base.startswith('rostest-')
        try:
            for name, status, msg in cases(f):
                if wrapper and status != 'failed':
                    continue
                if status == 'passed':
                    passed += 1
                elif status == 'skipped':
                    skipped += 1
                    if msg:
                        print('SKIPPED %s: %s  [%s]' % (name, msg[:200], base))
                else:
                    failed += 1
                    print('FAILED  %s: %s  [%s]' % (name, msg[:200], base))
        except ET.ParseError as e:
            failed += 1
            print('FAILED  %s: unreadable result file (%s)' % (base, e))
    line = '%d passed, %d failed' % (passed, failed)
    if skipped:
        line += ', %d skipped' % skipped
    print(line)
    return 1 if failed or passed == 0 else 0


if __name__ == '__main__':
    sys.exit(main())

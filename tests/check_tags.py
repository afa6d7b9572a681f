#!/usr/bin/env python3
"""The test tags against their list: every tag a TEST_CASE uses (in tests/ and rtl_sim/) must be in the table of
tests/README.md (section Tags), and every tag of the table must be used by some test.

Usage: check_tags.py SOURCE_DIR [EXTRA_FILE...]  (extra files are scanned as test sources too: the test that
shows the check refuses an unlisted tag passes one). Exits 1 naming each tag out of place, 0 otherwise.
"""
import pathlib
import re
import sys

STRING = r'"(?:[^"\\]|\\.)*"'
# TEST_CASE("name", "[a][b]"), the name and the tags each possibly several adjacent string literals.
CASE = re.compile(r'\b(?:TEST_CASE|TEMPLATE_TEST_CASE|SCENARIO)\s*\(\s*((?:%s\s*)+),\s*((?:%s\s*)+)' %
                  (STRING, STRING))
TAG = re.compile(r'\[([^\]]+)\]')


def used_tags(files):
    used = {}
    for path in files:
        text = path.read_text(encoding='utf-8', errors='replace')
        for m in CASE.finditer(text):
            tags = ''.join(re.findall(r'"((?:[^"\\]|\\.)*)"', m.group(2)))
            for tag in TAG.findall(tags):
                if tag.startswith(('.', '!')):  # Catch2's hide and behaviour tags
                    continue
                used.setdefault(tag, set()).add(str(path))
    return used


def listed_tags(readme):
    text = readme.read_text(encoding='utf-8')
    m = re.search(r'<!-- tags:[^\n]*-->\n(.*?)<!-- tags: end -->', text, re.S)
    if not m:
        sys.exit(f'check_tags: no tag table (<!-- tags: ... --> ... <!-- tags: end -->) in {readme}')
    listed = set()
    for line in m.group(1).splitlines():
        if line.startswith('| `['):
            listed.update(TAG.findall(line.split('|')[1]))
    return listed


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    root = pathlib.Path(sys.argv[1])
    files = [p for d in ('tests', 'rtl_sim') for p in sorted((root / d).rglob('*'))
             if p.suffix in ('.cpp', '.h') and p.is_file()]
    files += [pathlib.Path(f) for f in sys.argv[2:]]
    used = used_tags(files)
    listed = listed_tags(root / 'tests' / 'README.md')
    bad = 0
    for tag in sorted(set(used) - listed):
        print(f'check_tags: [{tag}] is used but not in the list of tests/README.md: ' +
              ', '.join(sorted(used[tag])))
        bad += 1
    for tag in sorted(listed - set(used)):
        print(f'check_tags: [{tag}] is in the list of tests/README.md but no test uses it')
        bad += 1
    if bad:
        return 1
    print(f'check_tags: {len(listed)} tags, each listed and used')
    return 0


if __name__ == '__main__':
    sys.exit(main())

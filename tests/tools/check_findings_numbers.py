#!/usr/bin/env python3
"""The book's findings chapters restate no result: every measured number comes from a generated
file they include (`{{#include ../../../reports/<study>/summary.md}}`, the fidelity summary).

Outside fenced code, headings and include lines, after removing code spans (`k = 0.1`: a setting of
the runs), citations ([FT Table 10.2: 10.4]: a published number) and link targets, a chapter may
not contain a decimal number, nor a number followed by a unit (m, cm, mm, cm², %, °, s, ms, µs, ×).
Integers alone (five maps, 100 particles, Table 4) and names with versions (FastSLAM 2.0) are
allowed.

Usage: check_findings_numbers.py DIR ; exits 1 naming each file:line and number."""
import os, re, sys

CITATION = re.compile(r'\[(?:FT|EP|PF|EV|CSM|Sc|HKSJ)\b[^\]]*\]')
CODE = re.compile(r'`[^`]*`')
LINK_TARGET = re.compile(r'\]\([^)]*\)')
NUMBER = re.compile(
    r'(?<![\w.])[−-]?\d[\d  ]*(?:\.\d+|(?:\s*(?:m|cm|mm|cm²|m²|%|°|s|ms|µs|×|x)(?![\w])))')
FENCE = re.compile(r'^\s*(```|~~~)')


NAME = re.compile(r'\b(?:FastSLAM|SALib|PSM|E-PSM)\s+v?\d+(?:\.\d+)+')


def offending(line):
    text = LINK_TARGET.sub('](…)', CITATION.sub('[…]', CODE.sub('`…`', line)))
    text = NAME.sub('…', text)  # names with versions: FastSLAM 1.0, SALib 1.6.0
    return [m.group(0).strip() for m in NUMBER.finditer(text)]


def main(root):
    bad = []
    for name in sorted(os.listdir(root)):
        if not name.endswith('.md'):
            continue
        path = os.path.join(root, name)
        fenced = False
        with open(path, encoding='utf-8') as f:
            for number, line in enumerate(f, 1):
                if FENCE.match(line):
                    fenced = not fenced
                if fenced or line.lstrip().startswith(('#', '{{#include', '<!--')):
                    continue
                for n in offending(line):
                    bad.append(f'{path}:{number}: {n!r}')
    for b in bad:
        print(b, file=sys.stderr)
    print(f'findings chapters: {len(bad)} restated numbers')
    return 1 if bad else 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1] if len(sys.argv) > 1 else 'docs/src/findings'))

#!/usr/bin/env python3
"""Every relative link of the README and the book points at a file that exists, and every
`#anchor` into a Markdown file at one of its headings (mdBook's heading ids).

Usage: check_links.py FILE_OR_DIR... ; exits 1 naming each broken link (file:line: target)."""
import os, re, sys

LINK = re.compile(r'(?<!!)\[[^\]]*\]\(([^)\s]+)(?:\s+"[^"]*")?\)|<a\s+href="([^"]+)"|!\[[^\]]*\]\(([^)\s]+)\)')
INCLUDE = re.compile(r'\{\{#include\s+([^}\s:]+)')
FENCE = re.compile(r'^\s*(```|~~~)')


def heading_ids(path):
    """mdBook's ids: lower case, alphanumerics, '-' and '_' kept, spaces to '-', the rest dropped;
    repeats get -1, -2, …"""
    ids, seen, fenced = set(), {}, False
    with open(path, encoding='utf-8') as f:
        for line in f:
            if FENCE.match(line):
                fenced = not fenced
            if fenced:
                continue
            m = re.match(r'^#{1,6}\s+(.*?)\s*#*\s*$', line)
            if not m:
                continue
            text = re.sub(r'`|\*|_(?=\w)|(?<=\w)_|\[|\]\([^)]*\)', '', m.group(1))
            slug = ''.join(c for c in text.lower().replace(' ', '-') if c.isalnum() or c in '-_')
            n = seen.get(slug, 0)
            seen[slug] = n + 1
            ids.add(slug if n == 0 else f'{slug}-{n}')
    return ids


def files(args):
    for a in args:
        if os.path.isdir(a):
            for root, _, names in os.walk(a):
                for n in sorted(names):
                    if n.endswith('.md'):
                        yield os.path.join(root, n)
        else:
            yield a


def main(args):
    broken, checked = [], 0
    for path in files(args):
        base = os.path.dirname(path)
        fenced = False
        with open(path, encoding='utf-8') as f:
            for number, line in enumerate(f, 1):
                if FENCE.match(line):
                    fenced = not fenced
                if fenced:
                    continue
                targets = [t for m in LINK.finditer(line) for t in m.groups() if t]
                targets += INCLUDE.findall(line)
                for target in targets:
                    if re.match(r'^[a-z]+:', target) or target.startswith('//'):
                        continue  # http(s), mailto: not checked here
                    checked += 1
                    file_part, _, anchor = target.partition('#')
                    dest = os.path.normpath(os.path.join(base, file_part)) if file_part else path
                    if not os.path.exists(dest):
                        broken.append(f'{path}:{number}: {target} (no {dest})')
                    elif anchor and dest.endswith('.md') and anchor not in heading_ids(dest):
                        broken.append(f'{path}:{number}: {target} (no heading #{anchor} in {dest})')
    for b in broken:
        print(b, file=sys.stderr)
    print(f'{checked} relative links checked, {len(broken)} broken')
    return 1 if broken else 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))

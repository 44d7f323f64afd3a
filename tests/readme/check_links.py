#!/usr/bin/env python3
"""readme_links test: every relative link and picture of the given Markdown files names a file
or folder of the repository, and a link's #anchor names a heading of the Markdown file it points
to (GitHub's heading anchors). Links inside code blocks and code spans are not links.

    check_links.py FILE.md...

Exit 0 when every link resolves, 1 otherwise (each broken link is printed with its file and
line), 2 on bad usage.
"""
import os
import re
import sys

LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
FENCE = re.compile(r"^\s*```")
CODE_SPAN = re.compile(r"`[^`]*`")
EXTERNAL = re.compile(r"^[a-zA-Z][a-zA-Z0-9+.-]*:")


def github_anchor(heading):
    """The anchor GitHub gives a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = heading.strip().lower().replace("`", "")
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors_of(path):
    anchors, seen, in_code = set(), {}, False
    with open(path, encoding="utf-8") as f:
        for line in f:
            if FENCE.match(line):
                in_code = not in_code
                continue
            match = re.match(r"^#{1,6}\s+(.*?)\s*#*\s*$", line)
            if in_code or not match:
                continue
            anchor = github_anchor(match.group(1))
            count = seen.get(anchor, 0)
            seen[anchor] = count + 1
            anchors.add(anchor if count == 0 else f"{anchor}-{count}")
    return anchors


def links_of(path):
    """(line number, target) of every link outside code."""
    in_code = False
    with open(path, encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            if FENCE.match(line):
                in_code = not in_code
                continue
            if in_code:
                continue
            for match in LINK.finditer(CODE_SPAN.sub("", line)):
                yield number, match.group(1)


def broken_links(path):
    for number, target in links_of(path):
        if EXTERNAL.match(target):
            continue
        file_part, _, anchor = target.partition("#")
        resolved = os.path.normpath(os.path.join(os.path.dirname(path), file_part)) if file_part \
            else path
        if not os.path.exists(resolved):
            yield f"{path}:{number}: {target}: no such file"
        elif anchor and resolved.endswith(".md") and anchor not in anchors_of(resolved):
            yield f"{path}:{number}: {target}: no heading #{anchor} in {resolved}"


def main(argv):
    if len(argv) < 2 or argv[1] in ("-h", "--help"):
        print(__doc__)
        return 0 if len(argv) == 2 else 2
    broken, checked = [], 0
    for path in argv[1:]:
        if not os.path.isfile(path):
            print(f"no such file: {path}", file=sys.stderr)
            return 2
        checked += sum(1 for _ in links_of(path))
        broken.extend(broken_links(path))
    for line in broken:
        print(line)
    print(f"{checked} links in {len(argv) - 1} files, {len(broken)} broken")
    return 1 if broken else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))

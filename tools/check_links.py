#!/usr/bin/env python3
"""Checks the relative links of README.md and docs/*.md: each must name an existing file and,
with a #fragment, a heading that exists in it (GitHub's slugs). Moving a section between pages
breaks links silently otherwise. Exit 1 and one line per broken link."""
import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")


def prose(text):
    """The text outside code fences and inline code, where links render."""
    text = re.sub(r"^```.*?^```", "", text, flags=re.S | re.M)
    return re.sub(r"`[^`\n]*`", "", text)


def slugs(path):
    seen, out = {}, set()
    in_fence = False
    for line in path.read_text(encoding="utf-8").splitlines():
        if line.startswith("```"):
            in_fence = not in_fence
        m = None if in_fence else re.match(r"#{1,6}\s+(.*)", line)
        if not m:
            continue
        s = re.sub(r"[^\w\- ]", "", m.group(1).strip().lower()).replace(" ", "-")
        n = seen.get(s, 0)
        seen[s] = n + 1
        out.add(s if n == 0 else f"{s}-{n}")
    return out


def main():
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    broken = []
    for page in pages:
        for target in LINK.findall(prose(page.read_text(encoding="utf-8"))):
            if re.match(r"[a-z]+:", target):
                continue  # http(s), mailto: not checked offline
            file, _, frag = target.partition("#")
            dest = (page.parent / file).resolve() if file else page
            rel = page.relative_to(ROOT)
            if not dest.exists():
                broken.append(f"{rel}: {target}: no such file")
            elif frag and dest.suffix == ".md" and frag not in slugs(dest):
                broken.append(f"{rel}: {target}: no heading #{frag} in {dest.relative_to(ROOT)}")
    print("\n".join(broken) or f"{len(pages)} pages, every relative link resolves")
    return 1 if broken else 0


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env python3
"""Puts back into a URDF prepared by strip_urdf.py the <visual> elements of each <link> and the
top-level <material> elements of its source (byte for byte), for coopdyn view to draw the robot.

usage: restore_visuals.py SOURCE.urdf STRIPPED.urdf OUT.urdf
"""
import re
import sys


def without_comments(text):
    return re.sub(r"<!--.*?-->", lambda m: " " * len(m.group(0)), text, flags=re.S)


def links(text):
    """name -> (start, end) of each <link ...>...</link> or <link .../> outside comments."""
    clean = without_comments(text)
    out = {}
    for m in re.finditer(r'<link\s+name="([^"]+)"\s*(/>|>.*?</link>)', clean, flags=re.S):
        out[m.group(1)] = (m.start(), m.end())
    return out


def main():
    src_path, stripped_path, out_path = sys.argv[1:4]
    src = open(src_path).read()
    dst = open(stripped_path).read()
    clean_src = without_comments(src)
    visuals = {}
    for name, (a, b) in links(src).items():
        body = clean_src[a:b]
        visuals[name] = [src[a + m.start():a + m.end()] for m in re.finditer(r"<visual\b.*?</visual>", body, flags=re.S)]
    # top-level materials: <material ...> directly under <robot> (outside every <link>)
    spans = sorted(links(src).values())
    mats = []
    for m in re.finditer(r'<material\s+name="[^"]+"\s*>.*?</material>', clean_src, flags=re.S):
        if not any(a <= m.start() < b for a, b in spans):
            mats.append(src[m.start():m.end()])
    restored = 0
    for name, (a, b) in sorted(links(dst).items(), key=lambda kv: -kv[1][0]):
        vs = visuals.get(name, [])
        if not vs:
            continue
        elem = dst[a:b]
        add = "".join("\n    " + v.strip() for v in vs)
        if elem.endswith("/>"):
            new = elem[:-2].rstrip() + ">" + add + "\n  </link>"
        else:
            new = elem[: -len("</link>")].rstrip() + add + "\n  </link>"
        dst = dst[:a] + new + dst[b:]
        restored += len(vs)
    robot = re.search(r"<robot\b[^>]*>", without_comments(dst))
    at = robot.end()
    dst = dst[:at] + "".join("\n  " + m for m in mats) + dst[at:]
    open(out_path, "w").write(dst)
    print(f"{out_path}: {restored} <visual> and {len(mats)} <material> restored from {src_path}")


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Strips a published (xacro-expanded) URDF down to what coopdyn reads, numbers untouched.

  bench/peers/strip_urdf.py IN.urdf OUT.urdf --repo OWNER/NAME --path PATH --commit SHA \
      --licence NAME [--licence-text FILE] [--upstream TEXT] [--wheel LINK ...]

Removes, as text (every other byte stays as published): every <visual>, <collision>, <gazebo> and
<transmission> element, the top-level <material> elements (used by visuals only), and the lines
they leave empty. A --wheel link keeps its <collision>/<visual> elements that hold a <cylinder>
(coopdyn reads a rolling wheel's radius from it). Comments are kept as published. A header
comment is written after the XML declaration: the source (repository, path, commit), the licence
(its full text from --licence-text, as BSD-style licences require of copies), and what was removed.

Check: the output is parsed again and every <link>, <joint> and top-level element other than the
removed ones is compared with the input's (tag, attributes, text, children, recursively, with the
removed children dropped from the input's side); any difference is an error (exit 1).
"""
import argparse
import re
import sys
import textwrap
import xml.etree.ElementTree as ET

DROP_ANYWHERE = ("visual", "collision", "gazebo", "transmission")


def protect_comments(text):
    comments = []

    def keep(m):
        comments.append(m.group(0))
        return "\x00%d\x00" % (len(comments) - 1)

    return re.sub(r"<!--.*?-->", keep, text, flags=re.S), comments


def restore_comments(text, comments):
    return re.sub("\x00(\\d+)\x00", lambda m: comments[int(m.group(1))], text)


def enclosing_link(text, pos):
    """Name of the <link> element that contains offset pos, or None."""
    start = text.rfind("<link", 0, pos)
    while start >= 0 and not re.match(r"<link[\s>/]", text[start:]):
        start = text.rfind("<link", 0, start)
    if start < 0 or text.find("</link>", start, pos) >= 0:
        return None
    m = re.match(r"<link\s[^>]*?name\s*=\s*[\"']([^\"']*)[\"']", text[start:])
    return m.group(1) if m else None


def cut(m):
    """What replaces a removed element: nothing, and its whole line if it stood alone on it."""
    lead, trail = m.group("lead"), m.group("trail")
    if lead is not None and trail is not None:
        return ""
    return (lead or "") + ("\n" if trail else "")


def strip(text, wheels):
    body, comments = protect_comments(text)
    removed = {}

    def drop(m):
        tag = m.group("tag")
        if tag in ("visual", "collision") and "<cylinder" in m.group(0):
            if enclosing_link(body, m.start("tag")) in wheels:
                return m.group(0)
        removed[tag] = removed.get(tag, 0) + 1
        return cut(m)

    element = r"(?P<lead>^[ \t]*)?<(?P<tag>%s)\b[^>]*?(?:/>|>.*?</(?P=tag)\s*>)(?P<trail>[ \t]*\n)?"
    body = re.sub(element % "|".join(DROP_ANYWHERE), drop, body, flags=re.S | re.M)

    # top-level <material> (a direct child of <robot>): depth 1
    root = re.search(r"<robot\b[^>]*>", body)
    spans, depth = [], 0
    for m in re.finditer(r"<(/?)([A-Za-z_][\w:.-]*)\b[^>]*?(/?)>", body, flags=re.S):
        if m.start() < root.start() or (spans and m.start() < spans[-1][1]):
            continue
        closing, tag, selfclosing = m.group(1), m.group(2), m.group(3)
        if tag == "material" and depth == 1 and not closing:
            end = m.end() if selfclosing else body.index("</material>", m.end()) + len("</material>")
            spans.append((m.start(), end))
        elif closing:
            depth -= 1
        elif not selfclosing:
            depth += 1
    for a, b in reversed(spans):
        lead = re.search(r"(^|\n)([ \t]*)$", body[:a])
        trail = re.match(r"[ \t]*\n", body[b:])
        if lead and trail:
            a, b = a - len(lead.group(2)), b + len(trail.group(0))
        body = body[:a] + body[b:]
        removed["material"] = removed.get("material", 0) + 1
    return restore_comments(body, comments), removed


def comparable(elem):
    """(tag, attributes, text, children) with the dropped elements left out, recursively."""
    kids = [comparable(c) for c in elem if c.tag not in DROP_ANYWHERE]
    text = (elem.text or "").strip()
    return (elem.tag, tuple(sorted(elem.attrib.items())), text, tuple(kids))


def check(src, out, wheels):
    a, b = ET.fromstring(src.encode()), ET.fromstring(out.encode())
    keep = lambda root: [c for c in root if c.tag not in DROP_ANYWHERE and c.tag != "material"]
    ka, kb = keep(a), keep(b)
    if len(ka) != len(kb):
        return "element count differs: %d in the input, %d in the output" % (len(ka), len(kb))
    for x, y in zip(ka, kb):
        if comparable(x) != comparable(y):
            return "element differs: <%s name=%r>" % (x.tag, x.get("name"))
    # a wheel keeps its cylinder
    for w in wheels:
        link = b.find("./link[@name='%s']" % w)
        if link is None:
            return "--wheel %s: no such link" % w
        if link.find(".//cylinder") is None:
            return "--wheel %s: the link has no cylinder (give the radius in the scene)" % w
    return None


def header(args, removed):
    what = ", ".join("%d <%s>" % (n, t) for t, n in sorted(removed.items()))
    paragraphs = [
        args.title,
        "Source: https://github.com/%s, %s (commit %s). Licence: %s."
        % (args.repo, args.path, args.commit, args.licence),
        "Upstream: %s" % args.upstream if args.upstream else None,
        "Prepared for coopdyn by bench/peers/strip_urdf.py, which removed %s%s%s; every <link>, "
        "<joint>, <inertial>, <origin>, <axis>, <limit>, <dynamics>, <mimic>, comment and attribute "
        "otherwise as in the source, byte for byte."
        % (what, " (of <material>, the top-level ones only)" if "material" in removed else "",
           "; kept: the <cylinder> of the wheel links " + ", ".join(args.wheel) if args.wheel else ""),
    ]
    lines = ["<!--"]
    for text in paragraphs:
        if text:
            lines.extend(textwrap.wrap(text.replace("--", "- -"), 100, initial_indent="  ",
                                       subsequent_indent="  ", break_on_hyphens=False))
    if args.licence_text:
        with open(args.licence_text, encoding="utf-8") as f:
            lic = re.sub(r"-(?=-)", "- ", f.read()).rstrip("\n")  # no "--" inside a comment
        lines.append("")
        lines.extend(("  " + l).rstrip() for l in lic.split("\n"))
    lines.append("-->")
    return "\n".join(lines) + "\n"


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("input")
    p.add_argument("output")
    p.add_argument("--repo", required=True)
    p.add_argument("--path", required=True)
    p.add_argument("--commit", required=True)
    p.add_argument("--licence", required=True)
    p.add_argument("--licence-text")
    p.add_argument("--upstream")
    p.add_argument("--title")
    p.add_argument("--wheel", action="append", default=[])
    args = p.parse_args()
    with open(args.input, encoding="utf-8") as f:
        src = f.read()
    out, removed = strip(src, set(args.wheel))
    problem = check(src, out, args.wheel)
    if problem:
        sys.exit("strip_urdf.py: %s: %s" % (args.input, problem))
    m = re.match(r"\s*<\?xml[^>]*\?>\s*\n", out)
    decl, rest = (m.group(0), out[m.end():]) if m else ('<?xml version="1.0"?>\n', out)
    with open(args.output, "w", encoding="utf-8") as f:
        f.write(decl + header(args, removed) + rest)
    print("%s: %s" % (args.output, ", ".join("%d <%s>" % (n, t) for t, n in sorted(removed.items()))))


if __name__ == "__main__":
    main()

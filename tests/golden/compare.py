"""Compares two output trees (tests/golden/outputs.sh): every file the same text with the numbers
taken out, and every number equal to within rtol * (1 + |expected|). Byte-identical files are
counted; the others are listed with their largest difference. -march=native makes the last bits of
a result depend on the CPU (FMA, vector width), so a tolerance, not bytes, is what another machine can
be held to; on the machine that wrote expected/ a change that is meant to leave outputs alone leaves
them byte-identical, and this prints how many are.
Usage: compare.py EXPECTED_DIR ACTUAL_DIR [RTOL]"""
import os, re, sys

NUM = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?|[-+]?(?:nan|inf)\b")


def split(text):
    return NUM.sub("#", text), NUM.findall(text)


def main():
    exp_dir, act_dir = sys.argv[1], sys.argv[2]
    rtol = float(sys.argv[3]) if len(sys.argv) > 3 else 1e-7
    names = sorted(set(os.listdir(exp_dir)) | set(os.listdir(act_dir)))
    identical, within, failed = 0, [], []
    for n in names:
        e_path, a_path = os.path.join(exp_dir, n), os.path.join(act_dir, n)
        if not os.path.exists(e_path) or not os.path.exists(a_path):
            failed.append(f"{n}: only in {'actual' if os.path.exists(a_path) else 'expected'}")
            continue
        e, a = open(e_path).read(), open(a_path).read()
        if e == a:
            identical += 1
            continue
        e_text, e_num = split(e)
        a_text, a_num = split(a)
        if e_text != a_text or len(e_num) != len(a_num):
            el, al = e.splitlines(), a.splitlines()
            line = next((i for i in range(min(len(el), len(al))) if split(el[i])[0] != split(al[i])[0]),
                        min(len(el), len(al)))
            failed.append(f"{n}: text differs at line {line + 1}:\n  - {el[line][:200] if line < len(el) else ''}"
                          f"\n  + {al[line][:200] if line < len(al) else ''}")
            continue
        worst = 0.0
        for x, y in zip(e_num, a_num):
            if x == y:
                continue
            fx, fy = float(x), float(y)
            err = abs(fx - fy) / (1 + abs(fx))
            if not err <= rtol:  # NaN against a number fails too
                err = float("inf") if err != err else err
            worst = max(worst, err)
        (within if worst <= rtol else failed).append(f"{n}: largest difference {worst:.3g} (relative, 1 + |x|)")
    print(f"{identical} of {len(names)} outputs byte-identical, {len(within)} equal to within {rtol:g}")
    for line in within:
        print("  within: " + line)
    for line in failed:
        print("  DIFFERS: " + line)
    return 1 if failed else 0


sys.exit(main())

"""Compares a regenerated tests/golden/expected.json with an earlier copy, for the commit that
regenerates it (not run by the test suite):

    cp tests/golden/expected.json /tmp/before.json; python tests/golden/make.py reports
    python tests/golden/compare.py /tmp/before.json

Per case and door: the reals changed and their largest relative change, the non-real changes (a
fault's name, type or degradation model, a flag, a list's length: a changed diagnosis), and the
reals that moved by more than 0.5 %."""
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from tests.test_golden import laid_out  # noqa: E402
old = json.load(open(sys.argv[1])); new = json.load(open(Path(__file__).resolve().parent / "expected.json"))
def parse(t):
    try: return [json.loads(t)]
    except json.JSONDecodeError: return [json.loads(l) for l in t.splitlines()]
def walk(g, w, where, out):
    if isinstance(w, dict):
        if not isinstance(g, dict): out.append((where, "keys", None)); return
        if list(g) != list(w): out.append((where, "keys", sorted(set(g) ^ set(w))))   # keys added or removed
        for k in w:
            if k in g: walk(g[k], w[k], where + "." + k, out)                        # and the common ones compared
    elif isinstance(w, list):
        if not isinstance(g, list) or len(g) != len(w): out.append((where, "len", None)); return
        for i, (a, b) in enumerate(zip(g, w)): walk(a, b, f"{where}[{i}]", out)
    elif isinstance(w, float) and isinstance(g, (int, float)) and not isinstance(g, bool):
        if g != w: out.append((where, "float", abs(g - w) / max(abs(w), 1e-300), g, w))
    elif g != w or type(g) is not type(w): out.append((where, "other", (g, w)))
assert list(old) == list(new)
for case in old:
    assert list(old[case]) == list(new[case])
    for door in old[case]:
        out = []
        walk(parse(laid_out(new[case][door], door)), parse(laid_out(old[case][door], door)), "", out)
        fl = [x for x in out if x[1] == "float"]; oth = [x for x in out if x[1] != "float"]
        big = [x for x in fl if x[2] > 5e-3]
        print(f"{case:16} {door:9} reals changed {len(fl):5}  max rel {max([x[2] for x in fl], default=0):.2e}  non-real changes {len(oth)}  beyond 0.5 %: {len(big)}")
        for x in oth[:5]: print("    NON-REAL", x)
        for x in big[:4]: print("    >0.5%", x[0], "%.3g -> %.3g (%.2e)" % (x[4], x[3], x[2]))

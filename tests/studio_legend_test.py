"""The studio's legend (studio/web/app.js SUBSIDENCE_TABLE: what each colour
becomes at each Subsidence) says what docs/INFERENCE.md's table of the shipped
model's training data says: the same median metres and share above the sea,
colour by colour and band by band (the legend said a bright lagoon was a
+41 m plain after the model had been retrained on lagoons of water)."""
import re
import sys

root = sys.argv[1]
doc = open(root + "/docs/INFERENCE.md", encoding="utf-8").read()
js = open(root + "/studio/web/app.js", encoding="utf-8").read()
rows = {}
for name in ["yellow island", "green beach", "cyan lagoon", "blue reef", "red abyss"]:
    line = next(l for l in doc.splitlines() if l.startswith("| " + name + " |"))
    cells = [c.strip() for c in line.split("|")[2:-1]]
    rows[name] = [(int(re.match(r"(−?-?\d+)", c).group(1).replace("−", "-")),
                   int(re.search(r"(\d+) % dry", c).group(1)) / 100) for c in cells]
table = js[js.index("const SUBSIDENCE_TABLE = ["):js.index("];", js.index("const SUBSIDENCE_TABLE = ["))]
legend = [[(int(m), float(d)) for m, d in re.findall(r"\[(-?\d+), ([\d.]+)\]", line)]
          for line in table.splitlines()[1:] if "[[" in line]
assert len(legend) == 5, legend
for name, got in zip(rows, legend):
    want = rows[name]
    assert len(got) == len(want) == 6, (name, got)
    for band, ((m, d), (wm, wd)) in enumerate(zip(got, want)):
        assert m == wm and abs(d - wd) < 0.005, f"{name}, band {band}: legend {m} m {d}, docs {wm} m {wd}"
print("studio legend = docs/INFERENCE.md: 5 colours × 6 bands")

# Writes inverted-ball.ply beside this script (git-ignored): tests/mitsuba/ball.ply with every vertex
# normal negated, so that the normals point against the winding (inverted-normals.xml; README "Not done").
# Run with any python3: python3 docs/mitsuba-differences/make-inverted-ball.py
import os

here = os.path.dirname(os.path.abspath(__file__))
lines = open(os.path.join(here, "../../tests/mitsuba/ball.ply")).read().split("\n")
end = lines.index("end_header")
count = next(int(l.split()[2]) for l in lines[:end] if l.startswith("element vertex"))
out = lines[: end + 1]
for line in lines[end + 1 : end + 1 + count]:
    v = line.split()
    v[3:6] = [str(-float(x)) for x in v[3:6]]
    out.append(" ".join(v))
out += lines[end + 1 + count :]
open(os.path.join(here, "inverted-ball.ply"), "w").write("\n".join(out))

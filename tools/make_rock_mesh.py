"""Generate data/meshes/rock.obj: a lumpy low-poly rock (a subdivided icosahedron with radial noise).

Deterministic (fixed seed); run once, committed.  Units: metres, about 1 m across
(rigsim scales meshes to the requested size anyway).
"""

from pathlib import Path

import numpy as np


def icosphere(levels: int = 2):
    t = (1 + 5**0.5) / 2
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
         (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6),
         (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10),
         (8, 6, 7), (9, 8, 1)]
    verts = [np.array(p, float) / np.linalg.norm(p) for p in v]
    for _ in range(levels):
        cache, nf = {}, []

        def mid(a, b):
            k = (min(a, b), max(a, b))
            if k not in cache:
                m = verts[a] + verts[b]
                verts.append(m / np.linalg.norm(m))
                cache[k] = len(verts) - 1
            return cache[k]

        for a, b, c in f:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            nf += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        f = nf
    return np.array(verts), np.array(f)


def main():
    rng = np.random.default_rng(20261122)
    v, f = icosphere(2)
    bumps = rng.normal(size=(6, 3))
    r = 0.5 * (1 + 0.12 * np.sum(np.sin(v @ bumps.T * 2.5), axis=1) / 3)
    v = v * r[:, None] * np.array([1.0, 0.7, 0.85])
    out = Path(__file__).resolve().parents[1] / "data" / "meshes" / "rock.obj"
    lines = ["# rigsim procedural rock: tools/make_rock_mesh.py (seed 20261122); units m; +y up, +z towards the camera"]
    lines += [f"v {x:.5f} {y:.5f} {z:.5f}" for x, y, z in v]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in f]
    out.write_text("\n".join(lines) + "\n")
    print(out, len(v), "vertices", len(f), "faces")


if __name__ == "__main__":
    main()

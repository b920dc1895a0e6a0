#!/usr/bin/env python3
"""Where a frame's error against the path tracer lies, from the fidelity table's dumps.

`GLINT_BENCH_FIDELITY_DUMP=DIR` makes the view bench's fidelity table write, per scene and
camera (STEM, e.g. `breakfast-room-front`): the two path-traced references
(`STEM-ref-a.f32`, `STEM-ref-b.f32`), the viewer's frame per mode (`STEM-geometry.f32`,
`STEM-image.f32`, `STEM-off.f32`, ...), little-endian f32 RGB rows; the primary hit's material
and object per pixel centre (`STEM-hits.u32`, u32::MAX for a miss), the materials' names
(`STEM-materials.txt`) and the objects' (`STEM-objects.txt`, glTF node names; dumps from
before 2026-12-08 have none). This script reads them with the standard library alone.

The error is the bench's: relative RMSE over pixels and channels, each squared difference
over (reference² + 0.01), the reference being the mean of the two path-traced images. It is
not the "noise out" figure: the references' own noise is in it. A pixel is an *edge* pixel
when one of its eight neighbours' centres meets another object.

    fidelity_dump.py worst DIR STEM MODE [-n 25]        the worst pixels, edge share, the
                                                       error without the worst k
    fidelity_dump.py materials DIR[,DIR2...] STEM MODE  per material: pixels, share of the
                                                       squared error, mean over the path
                                                       tracer's, error (each run's)
    fidelity_dump.py objects DIR[,DIR2...] STEM MODE MATERIAL
                                                       the same per object of one material
    fidelity_dump.py pixel DIR STEM MODE X,Y            the 7×5 pixels about (X, Y): frame /
                                                       reference luminance, material, object

Example (after a fidelity run with the dump):

    python3 benches/tools/fidelity_dump.py worst /tmp/dump breakfast-room-front geometry
"""

import argparse
import array
import os
import sys

MISS = 0xFFFFFFFF
EPSILON = 1e-2  # glint::eval::compare::REL_EPSILON


def read_array(path, code):
    """A little-endian array of `code` ("f": f32, "I": u32) from `path`."""
    a = array.array(code)
    with open(path, "rb") as f:
        a.frombytes(f.read())
    if sys.byteorder != "little":
        a.byteswap()
    return a


def read_lines(path):
    """The lines of `path`, none where it does not exist."""
    if not os.path.exists(path):
        return []
    with open(path) as f:
        return f.read().split("\n")


class Dump:
    def __init__(self, folder, stem, mode, size):
        self.w, self.h = size
        base = os.path.join(folder, stem)
        self.frame = read_array(f"{base}-{mode}.f32", "f")
        a, b = read_array(f"{base}-ref-a.f32", "f"), read_array(f"{base}-ref-b.f32", "f")
        self.ref = array.array("f", ((x + y) / 2 for x, y in zip(a, b)))
        n = self.w * self.h
        if len(self.frame) != 3 * n:
            sys.exit(f"{base}-{mode}.f32 holds {len(self.frame) // 3} pixels, not {self.w}×{self.h}: pass --size")
        hits = read_array(f"{base}-hits.u32", "I")
        self.material = hits[0::2]
        self.object = hits[1::2]
        self.names = read_lines(f"{base}-materials.txt")
        self.objects = read_lines(f"{base}-objects.txt")

    def name(self, i):
        m = self.material[i]
        return "(miss)" if m == MISS else self.names[m]

    def object_name(self, i):
        o = self.object[i]
        if o == MISS:
            return "(miss)"
        return f"{o} {self.objects[o]}" if o < len(self.objects) else str(o)

    def sq(self, i):
        """The pixel's squared relative error, summed over its channels."""
        s = 0.0
        for k in range(3):
            y = self.ref[3 * i + k]
            d = self.frame[3 * i + k] - y
            s += d * d / (y * y + EPSILON)
        return s

    def edge(self, i):
        x, y, o = i % self.w, i // self.w, self.object[i]
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                xx, yy = x + dx, y + dy
                if 0 <= xx < self.w and 0 <= yy < self.h and self.object[yy * self.w + xx] != o:
                    return True
        return False


def lum(rgb, i):
    return 0.2126 * rgb[3 * i] + 0.7152 * rgb[3 * i + 1] + 0.0722 * rgb[3 * i + 2]


def worst(args):
    d = Dump(args.dir, args.stem, args.mode, args.size)
    n = d.w * d.h
    sq = [d.sq(i) for i in range(n)]
    total = sum(sq)
    print(f"relative RMSE {(total / (3 * n)) ** 0.5:.4f} over {n} pixels")
    order = sorted(range(n), key=lambda i: -sq[i])
    run = 0.0
    for i in order[: args.n]:
        run += sq[i]
        print(
            f"{i % d.w:4d},{i // d.w:4d}  share {100 * sq[i] / total:5.2f}%  cumulative {100 * run / total:5.1f}%  "
            f"frame {lum(d.frame, i):.3f}  path tracer {lum(d.ref, i):.3f}  {d.name(i)} (object {d.object_name(i)})"
            + ("  edge" if d.edge(i) else "")
        )
    edges = [i for i in range(n) if d.edge(i)]
    share = sum(sq[i] for i in edges) / total
    print(f"edge pixels: {100 * len(edges) / n:.1f}% of the frame, {100 * share:.1f}% of the squared error")
    for k in (10, 50, 200):
        rest = total - sum(sq[i] for i in order[:k])
        print(f"without the worst {k}: {(rest / (3 * n)) ** 0.5:.4f}")


def grouped(args, key, keep):
    dumps = [Dump(f, args.stem, args.mode, args.size) for f in args.dir.split(",")]
    first = dumps[0]
    n = first.w * first.h
    rows = {}
    errors = [[d.sq(i) for i in range(n)] for d in dumps]
    totals = [sum(e) for e in errors]
    for i in range(n):
        if not keep(first, i):
            continue
        r = rows.setdefault(key(first, i), [0, 0.0] + [[0.0, 0.0] for _ in dumps])
        r[0] += 1
        r[1] += lum(first.ref, i)
        for k, d in enumerate(dumps):
            r[2 + k][0] += errors[k][i]
            r[2 + k][1] += lum(d.frame, i)
    names = [os.path.basename(f.rstrip("/")) for f in args.dir.split(",")]
    for label, r in sorted(rows.items(), key=lambda kv: -kv[1][2][0]):
        cells = []
        for k, (s, f) in enumerate(r[2:]):
            mean = f / r[1] if r[1] > 0 else float("nan")
            cells.append(
                f"{names[k]}: share {100 * s / totals[k]:5.1f}%  mean {mean:.3f}  error {(s / (3 * r[0])) ** 0.5:.3f}"
            )
        print(f"{label:24s} {r[0]:6d} px  " + "  |  ".join(cells))


def materials(args):
    grouped(args, lambda d, i: d.name(i), lambda d, i: True)


def objects(args):
    grouped(args, lambda d, i: f"object {d.object_name(i)}", lambda d, i: d.name(i) == args.material)


def pixel(args):
    d = Dump(args.dir, args.stem, args.mode, args.size)
    cx, cy = (int(v) for v in args.at.split(","))
    for y in range(cy - 2, cy + 3):
        cells = []
        for x in range(cx - 3, cx + 4):
            if not (0 <= x < d.w and 0 <= y < d.h):
                continue
            i = y * d.w + x
            cells.append(f"{lum(d.frame, i):6.3f}/{lum(d.ref, i):6.3f} {d.name(i)[:6]:6s}{d.object[i] % 1000:4d}")
        print(" | ".join(cells))


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--size", default="192x128", help="the fidelity table's frame, WxH (GLINT_BENCH_FIDELITY_SIZE)")
    sub = p.add_subparsers(dest="what", required=True)
    for name, f in (("worst", worst), ("materials", materials), ("objects", objects), ("pixel", pixel)):
        s = sub.add_parser(name)
        s.add_argument("dir")
        s.add_argument("stem")
        s.add_argument("mode")
        if name == "worst":
            s.add_argument("-n", type=int, default=25)
        if name == "objects":
            s.add_argument("material")
        if name == "pixel":
            s.add_argument("at", metavar="X,Y")
        s.set_defaults(run=f)
    args = p.parse_args()
    w, h = args.size.lower().split("x")
    args.size = (int(w), int(h))
    args.run(args)


if __name__ == "__main__":
    main()

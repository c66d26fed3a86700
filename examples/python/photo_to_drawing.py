"""Photo to pen drawing, after the MakerBot blog's photo-to-post-it script.

The steps, in order:
  1. find the photo's edges (grayscale, blur, Canny, thinning) and trace the
     edge pixels into polylines, simplified (motet.trace_edges does this part
     in Rust);
  2. order the polylines so the pen travels little between them;
  3. fit them to the paper, keeping the aspect ratio;
  4. draw them on the machine, one call per point, streamed as they come.

Run from the repository root after installing the bindings
(pip install ./crates/motet-py):

    python examples/python/photo_to_drawing.py [PHOTO] [OUT_DIR]
"""
import math
import sys

import motet


def order(polylines, start=(0.0, 0.0)):
    """Greedy nearest neighbour: next the line whose nearer end is closest;
    lines may be drawn backwards."""
    left = list(polylines)
    here, out = start, []
    while left:
        best, best_d, flip = 0, math.inf, False
        for i, line in enumerate(left):
            for rev, end in ((False, line[0]), (True, line[-1])):
                d = math.dist(here, end)
                if d < best_d:
                    best, best_d, flip = i, d, rev
        line = left.pop(best)
        line = line[::-1] if flip else line
        out.append(line)
        here = line[-1]
    return out


def fit(polylines, width_px, height_px, paper, margin):
    """Pixels (y down) to millimetres on the paper (y up), centred."""
    (x0, y0), (x1, y1) = paper
    scale = min((x1 - x0 - 2 * margin) / width_px, (y1 - y0 - 2 * margin) / height_px)
    ox = (x0 + x1 - width_px * scale) / 2
    oy = (y0 + y1 - height_px * scale) / 2
    return [[(ox + x * scale, oy + (height_px - y) * scale) for x, y in line] for line in polylines]


def draw(machine, polylines, feed):
    for line in polylines:
        machine.set_tool("pen", 0.0)
        machine.rapid_to(x=line[0][0], y=line[0][1])
        machine.set_tool("pen", 1.0)
        for x, y in line[1:]:
            machine.move_to(x=x, y=y, feed=feed)
    machine.set_tool("pen", 0.0)


def main():
    photo = sys.argv[1] if len(sys.argv) > 1 else "examples/photos/portrait.jpg"
    out = sys.argv[2] if len(sys.argv) > 2 else "out/photo"
    width_px, height_px, lines = motet.trace_edges(photo, max_px=400)
    lines = order(lines)
    with motet.Machine("examples/plotter.toml") as m:
        paper = ((0.0, 0.0), (300.0, 218.0))
        draw(m, fit(lines, width_px, height_px, paper, margin=15.0), feed=60.0)
        m.rapid_to(x=0, y=0)
    m.save(out)
    r = m.report()
    print(f"{len(lines)} strokes, {r['tool_on_distance_mm']:.0f} mm drawn in "
          f"{r['duration_s']:.0f} s; wrote {out}/path.png")


if __name__ == "__main__":
    main()

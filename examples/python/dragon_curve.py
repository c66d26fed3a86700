"""A Gestalt-style script: draw a dragon curve on the pen plotter, move by move.

No G-code file in between: each segment is a call, planned and streamed to the
machine as it is made. Run from the repository root after installing the
bindings (pip install ./crates/motet-py):

    python examples/python/dragon_curve.py [ORDER] [OUT_DIR]
"""
import sys

import motet


def dragon_turns(order):
    """Turn directions of the dragon curve: +1 left, -1 right."""
    turns = []
    for _ in range(order):
        turns = turns + [1] + [-t for t in reversed(turns)]
    return turns


def dragon_points(order, step):
    """Corner points of the curve, starting at the origin heading east."""
    x, y, dx, dy = 0.0, 0.0, step, 0.0
    points = [(x, y)]
    for turn in [0] + dragon_turns(order):
        if turn:
            dx, dy = -turn * dy, turn * dx  # rotate 90° left (+1) or right (-1)
        x, y = x + dx, y + dy
        points.append((x, y))
    return points


def fit(points, width, height, margin):
    """Scale and centre the points into a width × height area."""
    xs, ys = [p[0] for p in points], [p[1] for p in points]
    span = max(max(xs) - min(xs), max(ys) - min(ys))
    scale = (min(width, height) - 2 * margin) / span
    cx, cy = (max(xs) + min(xs)) / 2, (max(ys) + min(ys)) / 2
    return [(width / 2 + (x - cx) * scale, height / 2 + (y - cy) * scale) for x, y in points]


def main():
    order = int(sys.argv[1]) if len(sys.argv) > 1 else 12
    out = sys.argv[2] if len(sys.argv) > 2 else "out/dragon"
    with motet.Machine("examples/plotter.toml") as m:
        points = fit(dragon_points(order, 1.0), 300, 218, 15)
        m.rapid_to(x=points[0][0], y=points[0][1])
        m.set_tool("pen", 1.0)
        for x, y in points[1:]:
            m.move_to(x=x, y=y, feed=80)
        m.set_tool("pen", 0.0)
        m.rapid_to(x=0, y=0)
    report = m.report()
    m.save(out)
    print(f"dragon curve of order {order}: {len(points) - 1} moves, "
          f"{report['tool_on_distance_mm']:.0f} mm drawn in {report['duration_s']:.1f} s; "
          f"wrote {out}/path.png")


if __name__ == "__main__":
    main()

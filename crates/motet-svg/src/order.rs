//! Drawing order that cuts pen-up travel: greedy nearest neighbour over a
//! kd-tree, then a 2-opt pass over candidate neighbours, then a choice of the
//! best start vertex for every closed loop.

/// A polyline to be drawn. Open ones may be drawn end to start; closed ones
/// (points without the repeated first point) may start at any vertex.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Shape<'a> {
    pub pts: &'a [[f64; 2]],
    pub closed: bool,
}

/// Where a shape goes in the drawing order and how it is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Placed {
    /// Index into the shapes.
    pub index: usize,
    /// Open shape drawn from its last point to its first.
    pub reversed: bool,
    /// Closed shape started at this vertex.
    pub rotate: usize,
}

impl Placed {
    fn new(index: usize) -> Self {
        Placed {
            index,
            reversed: false,
            rotate: 0,
        }
    }
}

/// Where drawing `p` starts.
pub(crate) fn entry(shapes: &[Shape], p: Placed) -> [f64; 2] {
    let s = &shapes[p.index];
    if s.closed {
        s.pts[p.rotate]
    } else if p.reversed {
        s.pts[s.pts.len() - 1]
    } else {
        s.pts[0]
    }
}

/// Where drawing `p` ends.
pub(crate) fn exit(shapes: &[Shape], p: Placed) -> [f64; 2] {
    let s = &shapes[p.index];
    if s.closed {
        s.pts[p.rotate]
    } else if p.reversed {
        s.pts[0]
    } else {
        s.pts[s.pts.len() - 1]
    }
}

pub(crate) fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

fn dist2(a: [f64; 2], b: [f64; 2]) -> f64 {
    let (dx, dy) = (a[0] - b[0], a[1] - b[1]);
    dx * dx + dy * dy
}

/// Pen-up travel from `start` through `tour`; returns it and the end point.
pub(crate) fn travel(start: [f64; 2], shapes: &[Shape], tour: &[Placed]) -> (f64, [f64; 2]) {
    let mut pos = start;
    let mut sum = 0.0;
    for &p in tour {
        sum += dist(pos, entry(shapes, p));
        pos = exit(shapes, p);
    }
    (sum, pos)
}

/// Document order.
pub(crate) fn identity(n: usize) -> Vec<Placed> {
    (0..n).map(Placed::new).collect()
}

/// Work units (move evaluations, moved tour entries) the 2-opt pass may
/// spend; bounds its time (about 0.1 µs per unit in release builds).
const TWO_OPT_BUDGET: u64 = 40_000_000;
/// Most 2-opt sweeps over the tour.
const TWO_OPT_PASSES: usize = 50;
/// Candidate neighbours per shape for 2-opt.
const NEIGHBOURS: usize = 8;
/// Improvements smaller than this (mm) are not worth a move.
const GAIN: f64 = 1e-9;

/// An order for `shapes` starting at `start` whose pen-up travel is never
/// more than document order's.
pub(crate) fn optimize(start: [f64; 2], shapes: &[Shape]) -> Vec<Placed> {
    let n = shapes.len();
    if n == 0 {
        return Vec::new();
    }
    let doc = identity(n);
    let nn = nearest_neighbour(start, shapes);
    let mut tour = if travel(start, shapes, &nn).0 <= travel(start, shapes, &doc).0 {
        nn
    } else {
        doc
    };
    let mut budget = TWO_OPT_BUDGET;
    two_opt(start, shapes, &mut tour, &mut budget);
    rotate_loops(start, shapes, &mut tour);
    tour
}

/// Greedy: always draw the shape whose entry is nearest to the pen.
fn nearest_neighbour(start: [f64; 2], shapes: &[Shape]) -> Vec<Placed> {
    // Candidate entry points: both ends of open shapes, every vertex of
    // closed ones. Shape s owns point ids base[s]..base[s + 1].
    let mut base = Vec::with_capacity(shapes.len() + 1);
    let mut items: Vec<([f64; 2], u32)> = Vec::new();
    let mut owner: Vec<(u32, u32)> = Vec::new();
    for (s, sh) in shapes.iter().enumerate() {
        base.push(owner.len());
        let verts: Vec<usize> = if sh.closed {
            (0..sh.pts.len()).collect()
        } else {
            vec![0, sh.pts.len() - 1]
        };
        for v in verts {
            items.push((sh.pts[v], owner.len() as u32));
            owner.push((s as u32, v as u32));
        }
    }
    base.push(owner.len());
    let mut tree = KdTree::new(items);
    let mut pos = start;
    let mut tour = Vec::with_capacity(shapes.len());
    while let Some(id) = tree.nearest(pos) {
        let (s, v) = (owner[id as usize].0 as usize, owner[id as usize].1 as usize);
        let sh = &shapes[s];
        let p = if sh.closed {
            Placed {
                index: s,
                reversed: false,
                rotate: v,
            }
        } else {
            Placed {
                index: s,
                reversed: v != 0,
                rotate: 0,
            }
        };
        for id in base[s]..base[s + 1] {
            tree.remove(id as u32);
        }
        pos = exit(shapes, p);
        tour.push(p);
    }
    tour
}

/// 2-opt over candidate pairs: reverse a stretch of the tour (drawing each
/// open shape in it the other way) when that shortens the travel.
fn two_opt(start: [f64; 2], shapes: &[Shape], tour: &mut [Placed], budget: &mut u64) {
    let n = tour.len();
    if n < 2 {
        return;
    }
    // Neighbour lists by proximity of ends, found with a kd-tree over both
    // ends of every shape (as placed now).
    let mut items = Vec::with_capacity(2 * n);
    for &p in tour.iter() {
        items.push((entry(shapes, p), p.index as u32));
        if !shapes[p.index].closed {
            items.push((exit(shapes, p), p.index as u32));
        }
    }
    let tree = KdTree::new(items);
    let near = |q: [f64; 2], me: Option<usize>| -> Vec<u32> {
        let mut out: Vec<u32> = Vec::with_capacity(NEIGHBOURS);
        for id in tree.k_nearest(q, 2 * NEIGHBOURS + 2) {
            if Some(id as usize) != me && !out.contains(&id) && out.len() < NEIGHBOURS {
                out.push(id);
            }
        }
        out
    };
    let mut neigh: Vec<Vec<u32>> = vec![Vec::new(); shapes.len()];
    for &p in tour.iter() {
        let mut list = near(entry(shapes, p), Some(p.index));
        if !shapes[p.index].closed {
            for id in near(exit(shapes, p), Some(p.index)) {
                if !list.contains(&id) {
                    list.push(id);
                }
            }
        }
        neigh[p.index] = list;
    }
    let from_start = near(start, None);
    *budget = budget.saturating_sub(3 * n as u64 * NEIGHBOURS as u64);

    let mut pos = vec![0usize; shapes.len()];
    for (k, p) in tour.iter().enumerate() {
        pos[p.index] = k;
    }
    // Entry and exit of each tour position, kept next to each other so that
    // evaluating a move touches no shape data.
    let mut ends: Vec<[[f64; 2]; 2]> = tour
        .iter()
        .map(|&p| [entry(shapes, p), exit(shapes, p)])
        .collect();
    // Gain of reversing tour[i..=j].
    let gain = |ends: &[[[f64; 2]; 2]], i: usize, j: usize| -> f64 {
        let prev = if i == 0 { start } else { ends[i - 1][1] };
        let (a, b) = (ends[i][0], ends[j][1]);
        let mut old = dist(prev, a);
        let mut new = dist(prev, b);
        if let Some(next) = ends.get(j + 1) {
            old += dist(b, next[0]);
            new += dist(a, next[0]);
        }
        old - new
    };
    let apply =
        |tour: &mut [Placed], ends: &mut [[[f64; 2]; 2]], pos: &mut [usize], i: usize, j: usize| {
            tour[i..=j].reverse();
            ends[i..=j].reverse();
            for (k, (p, e)) in tour[i..=j].iter_mut().zip(&mut ends[i..=j]).enumerate() {
                if !shapes[p.index].closed {
                    p.reversed = !p.reversed;
                }
                e.swap(0, 1);
                pos[p.index] = i + k;
            }
        };
    for _ in 0..TWO_OPT_PASSES {
        let mut improved = false;
        for &c in &from_start {
            let j = pos[c as usize];
            *budget = budget.saturating_sub(1);
            if gain(&ends, 0, j) > GAIN {
                apply(tour, &mut ends, &mut pos, 0, j);
                *budget = budget.saturating_sub(j as u64 + 1);
                improved = true;
            }
        }
        for x in 0..n {
            if *budget == 0 {
                return;
            }
            let s = tour[x].index;
            for &c in &neigh[s] {
                let c = c as usize;
                // tour[x] may have moved after an applied move.
                let (x, y) = (pos[s], pos[c]);
                if x == y {
                    continue;
                }
                let (a, b) = (x.min(y), x.max(y));
                // New edge exit(a)-exit(b), or entry(a)-entry(b).
                for (i, j) in [(a + 1, b), (a, b - 1)] {
                    *budget = budget.saturating_sub(1);
                    if i <= j && gain(&ends, i, j) > GAIN {
                        apply(tour, &mut ends, &mut pos, i, j);
                        *budget = budget.saturating_sub((j - i + 1) as u64);
                        improved = true;
                        break;
                    }
                }
            }
        }
        if !improved || *budget == 0 {
            return;
        }
    }
}

/// Start every closed loop at the vertex that makes the way in and out
/// shortest.
fn rotate_loops(start: [f64; 2], shapes: &[Shape], tour: &mut [Placed]) {
    for i in 0..tour.len() {
        let sh = &shapes[tour[i].index];
        if !sh.closed {
            continue;
        }
        let prev = if i == 0 {
            start
        } else {
            exit(shapes, tour[i - 1])
        };
        let next = tour.get(i + 1).map(|&p| entry(shapes, p));
        let cost = |v: [f64; 2]| dist(prev, v) + next.map_or(0.0, |q| dist(v, q));
        let mut best = (cost(sh.pts[tour[i].rotate]), tour[i].rotate);
        for (k, &v) in sh.pts.iter().enumerate() {
            let c = cost(v);
            if c < best.0 - GAIN {
                best = (c, k);
            }
        }
        tour[i].rotate = best.1;
    }
}

/// Nearest-point queries over points with ids, with removal. Points that
/// coincide are one entry of the tree holding all their ids: a drawing with
/// thousands of shapes on the same spot (duplicated layers, a stamp) costs a
/// query per shape, not a walk over every copy.
pub(crate) struct KdTree {
    tree: PointTree,
    /// Ids at each distinct point, ascending.
    members: Vec<Vec<u32>>,
    /// First member of each distinct point that may still be alive.
    cursor: Vec<usize>,
    /// Alive members of each distinct point.
    left: Vec<u32>,
    /// Distinct point of each id (ids are 0..n when used with `remove`).
    point_of: Vec<u32>,
    dead: Vec<bool>,
}

impl KdTree {
    pub(crate) fn new(mut items: Vec<([f64; 2], u32)>) -> Self {
        items.sort_by_key(|i| i.1);
        let mut index: std::collections::HashMap<(u64, u64), u32> = Default::default();
        let mut points: Vec<([f64; 2], u32)> = Vec::new();
        let mut members: Vec<Vec<u32>> = Vec::new();
        let mut point_of = vec![u32::MAX; items.len()];
        for &(p, id) in &items {
            let key = (p[0].to_bits(), p[1].to_bits());
            let u = *index.entry(key).or_insert_with(|| {
                points.push((p, points.len() as u32));
                members.push(Vec::new());
                (points.len() - 1) as u32
            });
            members[u as usize].push(id);
            if let Some(slot) = point_of.get_mut(id as usize) {
                *slot = u;
            }
        }
        KdTree {
            tree: PointTree::new(points),
            cursor: vec![0; members.len()],
            left: members.iter().map(|m| m.len() as u32).collect(),
            members,
            point_of,
            dead: vec![false; items.len()],
        }
    }

    /// Remove the point with this id (ids must be 0..n, each once).
    pub(crate) fn remove(&mut self, id: u32) {
        let (Some(&u), Some(dead)) = (
            self.point_of.get(id as usize),
            self.dead.get_mut(id as usize),
        ) else {
            return;
        };
        if *dead || u == u32::MAX {
            return;
        }
        *dead = true;
        let u = u as usize;
        self.left[u] -= 1;
        if self.left[u] == 0 {
            self.tree.remove(u as u32);
        }
    }

    /// Id of the nearest alive point (the lowest id among coinciding ones).
    pub(crate) fn nearest(&mut self, q: [f64; 2]) -> Option<u32> {
        let u = self.tree.nearest(q)? as usize;
        let m = &self.members[u];
        let c = &mut self.cursor[u];
        while *c < m.len() && self.dead.get(m[*c] as usize).copied().unwrap_or(false) {
            *c += 1;
        }
        m.get(*c).copied()
    }

    /// Ids of up to `k` nearest points (alive or not), nearest first.
    pub(crate) fn k_nearest(&self, q: [f64; 2], k: usize) -> Vec<u32> {
        let mut out = Vec::with_capacity(k);
        for u in self.tree.k_nearest(q, k) {
            for &id in &self.members[u as usize] {
                if out.len() == k {
                    return out;
                }
                out.push(id);
            }
        }
        out
    }
}

/// Static 2-d tree over points with removal (alive counts per subtree), laid
/// out implicitly: the node of range `lo..hi` sits at `(lo + hi) / 2`.
struct PointTree {
    pts: Vec<[f64; 2]>,
    ids: Vec<u32>,
    /// Alive points in the subtree whose node is at this slot.
    alive: Vec<u32>,
    dead: Vec<bool>,
    /// Slot of each id (ids are 0..n when used with `remove`).
    slot_of: Vec<u32>,
}

impl PointTree {
    fn new(mut items: Vec<([f64; 2], u32)>) -> Self {
        let n = items.len();
        build(&mut items, 0);
        let mut alive = vec![0u32; n];
        count(&mut alive, 0, n);
        let mut slot_of = vec![u32::MAX; n];
        for (slot, (_, id)) in items.iter().enumerate() {
            if let Some(s) = slot_of.get_mut(*id as usize) {
                *s = slot as u32;
            }
        }
        PointTree {
            pts: items.iter().map(|i| i.0).collect(),
            ids: items.iter().map(|i| i.1).collect(),
            alive,
            dead: vec![false; n],
            slot_of,
        }
    }

    /// Remove the point with this id (ids must be 0..n, each once).
    fn remove(&mut self, id: u32) {
        let Some(&slot) = self.slot_of.get(id as usize) else {
            return;
        };
        let slot = slot as usize;
        if slot >= self.dead.len() || self.dead[slot] {
            return;
        }
        self.dead[slot] = true;
        let (mut lo, mut hi) = (0, self.pts.len());
        while lo < hi {
            let mid = (lo + hi) / 2;
            self.alive[mid] -= 1;
            if slot == mid {
                break;
            } else if slot < mid {
                hi = mid;
            } else {
                lo = mid + 1;
            }
        }
    }

    /// Id of the nearest alive point.
    fn nearest(&self, q: [f64; 2]) -> Option<u32> {
        let mut best = (f64::INFINITY, None);
        self.nearest_in(q, 0, self.pts.len(), 0, &mut best);
        best.1
    }

    fn nearest_in(
        &self,
        q: [f64; 2],
        lo: usize,
        hi: usize,
        axis: usize,
        best: &mut (f64, Option<u32>),
    ) {
        if lo >= hi {
            return;
        }
        let mid = (lo + hi) / 2;
        if self.alive[mid] == 0 {
            return;
        }
        let p = self.pts[mid];
        if !self.dead[mid] {
            let d = dist2(q, p);
            if d < best.0 || (d == best.0 && best.1.is_some_and(|b| self.ids[mid] < b)) {
                *best = (d, Some(self.ids[mid]));
            }
        }
        let diff = q[axis] - p[axis];
        let (first, second) = if diff < 0.0 {
            ((lo, mid), (mid + 1, hi))
        } else {
            ((mid + 1, hi), (lo, mid))
        };
        self.nearest_in(q, first.0, first.1, 1 - axis, best);
        if diff * diff <= best.0 {
            self.nearest_in(q, second.0, second.1, 1 - axis, best);
        }
    }

    /// Ids of up to `k` nearest points (alive or not), nearest first.
    fn k_nearest(&self, q: [f64; 2], k: usize) -> Vec<u32> {
        let mut best: Vec<(f64, u32)> = Vec::with_capacity(k + 1);
        self.k_nearest_in(q, k, 0, self.pts.len(), 0, &mut best);
        best.into_iter().map(|b| b.1).collect()
    }

    fn k_nearest_in(
        &self,
        q: [f64; 2],
        k: usize,
        lo: usize,
        hi: usize,
        axis: usize,
        best: &mut Vec<(f64, u32)>,
    ) {
        if lo >= hi || k == 0 {
            return;
        }
        let mid = (lo + hi) / 2;
        let p = self.pts[mid];
        let d = dist2(q, p);
        if best.len() < k || d < best[best.len() - 1].0 {
            let at = best.partition_point(|b| b.0 <= d);
            best.insert(at, (d, self.ids[mid]));
            best.truncate(k);
        }
        let diff = q[axis] - p[axis];
        let (first, second) = if diff < 0.0 {
            ((lo, mid), (mid + 1, hi))
        } else {
            ((mid + 1, hi), (lo, mid))
        };
        self.k_nearest_in(q, k, first.0, first.1, 1 - axis, best);
        if best.len() < k || diff * diff <= best[best.len() - 1].0 {
            self.k_nearest_in(q, k, second.0, second.1, 1 - axis, best);
        }
    }
}

fn build(items: &mut [([f64; 2], u32)], axis: usize) {
    if items.len() <= 1 {
        return;
    }
    let mid = items.len() / 2;
    items.select_nth_unstable_by(mid, |a, b| a.0[axis].total_cmp(&b.0[axis]));
    let (left, right) = items.split_at_mut(mid);
    build(left, 1 - axis);
    build(&mut right[1..], 1 - axis);
}

fn count(alive: &mut [u32], lo: usize, hi: usize) {
    if lo >= hi {
        return;
    }
    let mid = (lo + hi) / 2;
    alive[mid] = (hi - lo) as u32;
    count(alive, lo, mid);
    count(alive, mid + 1, hi);
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Brute force: the nearest alive id, the lowest among equals.
    fn brute(pts: &[[f64; 2]], alive: &[bool], q: [f64; 2]) -> Option<u32> {
        (0..pts.len())
            .filter(|&i| alive[i])
            .min_by(|&a, &b| {
                dist2(q, pts[a])
                    .total_cmp(&dist2(q, pts[b]))
                    .then(a.cmp(&b))
            })
            .map(|i| i as u32)
    }

    proptest::proptest! {
        /// With many coinciding points (a few distinct spots, each many
        /// times), queries and removals answer as a brute-force search does.
        #[test]
        fn coinciding_points_answer_like_brute_force(
            spots in proptest::collection::vec((0u8..4, 0u8..4), 1..200),
            queries in proptest::collection::vec((0u8..8, 0u8..8, 0usize..200), 1..60),
        ) {
            let pts: Vec<[f64; 2]> = spots.iter().map(|&(x, y)| [x as f64, y as f64]).collect();
            let mut tree = KdTree::new(pts.iter().enumerate().map(|(i, p)| (*p, i as u32)).collect());
            let mut alive = vec![true; pts.len()];
            for (x, y, kill) in queries {
                let q = [x as f64 * 0.5, y as f64 * 0.5];
                let got = tree.nearest(q);
                let want = brute(&pts, &alive, q);
                proptest::prop_assert_eq!(
                    got.map(|i| dist2(q, pts[i as usize])),
                    want.map(|i| dist2(q, pts[i as usize]))
                );
                if let Some(g) = got {
                    // The lowest alive id at the point found.
                    let low = (0..pts.len()).find(|&i| alive[i] && pts[i] == pts[g as usize]);
                    proptest::prop_assert_eq!(Some(g as usize), low);
                }
                let k = kill % pts.len();
                tree.remove(k as u32);
                alive[k] = false;
            }
        }
    }

    /// Random stroke sets straight through the optimiser.
    fn random_shapes(seed: u64, n: usize) -> Vec<(Vec<[f64; 2]>, bool)> {
        let mut x = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407)
            | 1;
        let mut rnd = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64
        };
        (0..n)
            .map(|_| {
                let c = [rnd() * 500.0, rnd() * 500.0];
                let closed = rnd() < 0.5;
                let k = 2 + (rnd() * 6.0) as usize;
                let pts = (0..k)
                    .map(|_| [c[0] + rnd() * 5.0, c[1] + rnd() * 5.0])
                    .collect();
                (pts, closed)
            })
            .collect()
    }

    fn check_tour(start: [f64; 2], set: &[(Vec<[f64; 2]>, bool)]) -> (f64, f64) {
        let shapes: Vec<Shape> = set
            .iter()
            .map(|(p, c)| Shape { pts: p, closed: *c })
            .collect();
        let tour = optimize(start, &shapes);
        let mut seen: Vec<usize> = tour.iter().map(|p| p.index).collect();
        seen.sort_unstable();
        assert_eq!(
            seen,
            (0..set.len()).collect::<Vec<_>>(),
            "not a permutation"
        );
        for p in &tour {
            let s = &shapes[p.index];
            assert!(p.rotate < s.pts.len());
            assert!(!(s.closed && p.reversed));
            assert!(s.closed || p.rotate == 0);
        }
        let before = travel(start, &shapes, &identity(set.len())).0;
        let after = travel(start, &shapes, &tour).0;
        (before, after)
    }

    #[test]
    fn ordering_many_paths() {
        for n in [1, 2, 3, 10, 1000, 10_000] {
            let set = random_shapes(n as u64, n);
            let t = std::time::Instant::now();
            let (before, after) = check_tour([0.0, 0.0], &set);
            println!(
                "{n} paths: travel {before:.0} -> {after:.0} mm in {:?}",
                t.elapsed()
            );
            assert!(after <= before + 1e-9);
            if n >= 1000 {
                assert!(after < 0.2 * before, "{before} -> {after}");
            }
        }
    }

    proptest! {
        #[test]
        fn optimizer_never_worse(seed in any::<u64>(), n in 1usize..60, start in (0.0f64..500.0, 0.0f64..500.0)) {
            let set = random_shapes(seed, n);
            let (before, after) = check_tour([start.0, start.1], &set);
            prop_assert!(after <= before + 1e-9, "{} -> {}", before, after);
        }
    }
}

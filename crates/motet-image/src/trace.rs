//! Edge pixels into chains of pixels.
//!
//! Pixels are linked by *m-adjacency* (mixed adjacency): the four side
//! neighbours always, a diagonal neighbour only when neither of the two side
//! pixels it shares with the centre is set. Connectivity is the same as with
//! 8-adjacency, but the staircases Canny leaves on slanted edges have one
//! path through them instead of small triangles, so every pixel on a plain
//! curve has exactly two neighbours and only real forks have three or more.

use std::collections::HashSet;

/// A set of edge pixels, row-major.
pub(crate) struct EdgeMap {
    pub width: u32,
    pub height: u32,
    pub set: Vec<bool>,
}

impl EdgeMap {
    fn is_set(&self, x: i64, y: i64) -> bool {
        x >= 0
            && y >= 0
            && x < self.width as i64
            && y < self.height as i64
            && self.set[(y as usize) * self.width as usize + x as usize]
    }

    /// m-adjacent set neighbours of pixel `p`, side neighbours first.
    fn neighbours(&self, p: u32) -> ([u32; 8], usize) {
        let w = self.width as i64;
        let (x, y) = ((p as i64) % w, (p as i64) / w);
        let mut out = [0u32; 8];
        let mut n = 0;
        let idx = |x: i64, y: i64| (y * w + x) as u32;
        for (dx, dy) in [(1, 0), (0, 1), (-1, 0), (0, -1)] {
            if self.is_set(x + dx, y + dy) {
                out[n] = idx(x + dx, y + dy);
                n += 1;
            }
        }
        for (dx, dy) in [(1, 1), (-1, 1), (-1, -1), (1, -1)] {
            if self.is_set(x + dx, y + dy) && !self.is_set(x + dx, y) && !self.is_set(x, y + dy) {
                out[n] = idx(x + dx, y + dy);
                n += 1;
            }
        }
        (out, n)
    }
}

/// Thins edges to one pixel: Canny keeps both pixels of a step that falls
/// exactly between two (as in drawings and synthetic images), which would
/// make every pixel of such an edge a fork.
///
/// Sequential thinning: in raster order, a pixel is removed when it is a
/// *simple point* (its 8-neighbours form one 8-connected group, Yokoi's
/// connectivity number is 1, so removing it changes no connectivity) and
/// not an end (it has at least two m-adjacent neighbours, so lines keep
/// their length); repeated until nothing changes. This also removes the
/// redundant corner pixels of staircases and right angles.
pub(crate) fn thin(map: &mut EdgeMap) {
    let w = map.width as i64;
    let mut live: Vec<u32> = (0..map.set.len() as u32)
        .filter(|&p| map.set[p as usize])
        .collect();
    loop {
        let mut changed = false;
        for &p in &live {
            let (x, y) = ((p as i64) % w, (p as i64) / w);
            let at = |dx: i64, dy: i64| map.is_set(x + dx, y + dy) as u8;
            // x1..x8: E, NE, N, NW, W, SW, S, SE (y down).
            let n = [
                at(1, 0),
                at(1, -1),
                at(0, -1),
                at(-1, -1),
                at(-1, 0),
                at(-1, 1),
                at(0, 1),
                at(1, 1),
            ];
            let c = |k: usize| 1 - n[k % 8];
            let yokoi: u8 = [0, 2, 4, 6]
                .iter()
                .map(|&k| c(k) - c(k) * c(k + 1) * c(k + 2))
                .sum();
            if yokoi == 1 && map.neighbours(p).1 >= 2 {
                map.set[p as usize] = false;
                changed = true;
            }
        }
        if !changed {
            return;
        }
        live.retain(|&p| map.set[p as usize]);
    }
}

/// A traced chain: pixel indices in drawing order.
pub(crate) struct Chain {
    pub pixels: Vec<u32>,
}

struct Tracer<'a> {
    map: &'a EdgeMap,
    degree: Vec<u8>,
    used: Vec<bool>,
    /// Links that touch a fork pixel and have been drawn (smaller index first).
    fork_links: HashSet<(u32, u32)>,
}

impl Tracer<'_> {
    fn is_fork(&self, p: u32) -> bool {
        self.degree[p as usize] >= 3
    }

    fn link(&mut self, a: u32, b: u32) {
        if self.is_fork(a) || self.is_fork(b) {
            self.fork_links.insert((a.min(b), a.max(b)));
        }
    }

    fn linked(&self, a: u32, b: u32) -> bool {
        self.fork_links.contains(&(a.min(b), a.max(b)))
    }

    /// Extends `chain` (whose pixels are all marked used) until it reaches a
    /// fork, a dead end, or an already drawn fork it can join.
    fn walk(&mut self, chain: &mut Vec<u32>) {
        loop {
            let cur = *chain.last().expect("chain is never empty");
            if chain.len() > 1 && self.is_fork(cur) {
                return;
            }
            let prev = (chain.len() > 1).then(|| chain[chain.len() - 2]);
            let (nb, n) = self.map.neighbours(cur);
            let nb = &nb[..n];
            if let Some(&next) = nb.iter().find(|&&q| !self.used[q as usize]) {
                self.used[next as usize] = true;
                self.link(cur, next);
                chain.push(next);
                continue;
            }
            // Dead end next to a fork that another chain already went
            // through: end on it so that the drawing stays connected.
            if let Some(&fork) = nb
                .iter()
                .find(|&&q| Some(q) != prev && self.is_fork(q) && !self.linked(cur, q))
            {
                self.link(cur, fork);
                chain.push(fork);
            }
            return;
        }
    }
}

/// Traces all set pixels of `map` into chains: first from end pixels (one
/// neighbour), then the branches leaving forks (three or more neighbours),
/// then the remaining closed loops. Every pixel starts or continues at most
/// one chain; fork pixels end chains and may end several of them.
pub(crate) fn trace(map: &EdgeMap) -> Vec<Chain> {
    let len = map.set.len();
    let degree: Vec<u8> = (0..len)
        .map(|p| {
            if map.set[p] {
                map.neighbours(p as u32).1 as u8
            } else {
                0
            }
        })
        .collect();
    let mut t = Tracer {
        map,
        degree,
        used: vec![false; len],
        fork_links: HashSet::new(),
    };
    let mut chains = Vec::new();

    // 1. Open chains from their end pixels.
    for p in 0..len {
        if map.set[p] && t.degree[p] == 1 && !t.used[p] {
            t.used[p] = true;
            let mut chain = vec![p as u32];
            t.walk(&mut chain);
            chains.push(Chain { pixels: chain });
        }
    }
    // 2. Branches between forks that no end pixel led to.
    for p in 0..len {
        if !(map.set[p] && t.degree[p] >= 3) {
            continue;
        }
        let (nb, n) = map.neighbours(p as u32);
        for &q in &nb[..n] {
            if t.used[q as usize] {
                continue;
            }
            t.used[p] = true;
            t.used[q as usize] = true;
            t.link(p as u32, q);
            let mut chain = vec![p as u32, q];
            t.walk(&mut chain);
            chains.push(Chain { pixels: chain });
        }
    }
    // 3. Closed loops (and isolated pixels).
    for p in 0..len {
        if map.set[p] && !t.used[p] {
            t.used[p] = true;
            let mut chain = vec![p as u32];
            t.walk(&mut chain);
            let last = *chain.last().expect("chain is never empty");
            if chain.len() > 2 {
                let (nb, n) = map.neighbours(last);
                if nb[..n].contains(&(p as u32)) {
                    chain.push(p as u32);
                }
            }
            chains.push(Chain { pixels: chain });
        }
    }
    chains
}

/// Size (in pixels) of the connected component of every set pixel; 0 for
/// pixels that are not set.
pub(crate) fn component_sizes(map: &EdgeMap) -> Vec<u32> {
    let len = map.set.len();
    let mut label = vec![u32::MAX; len];
    let mut sizes = Vec::new();
    let mut stack = Vec::new();
    for p in 0..len {
        if !map.set[p] || label[p] != u32::MAX {
            continue;
        }
        let id = sizes.len() as u32;
        let mut size = 0u32;
        label[p] = id;
        stack.push(p as u32);
        while let Some(q) = stack.pop() {
            size += 1;
            let (nb, n) = map.neighbours(q);
            for &r in &nb[..n] {
                if label[r as usize] == u32::MAX {
                    label[r as usize] = id;
                    stack.push(r);
                }
            }
        }
        sizes.push(size);
    }
    label
        .iter()
        .map(|&l| if l == u32::MAX { 0 } else { sizes[l as usize] })
        .collect()
}

/// Whether pixel `p` is a fork (three or more m-adjacent neighbours).
pub(crate) fn is_fork(map: &EdgeMap, p: u32) -> bool {
    map.neighbours(p).1 >= 3
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map(rows: &[&str]) -> EdgeMap {
        let width = rows[0].len() as u32;
        let height = rows.len() as u32;
        let set = rows
            .iter()
            .flat_map(|r| r.bytes().map(|b| b == b'#'))
            .collect();
        EdgeMap { width, height, set }
    }

    fn all_pixels_covered(m: &EdgeMap, chains: &[Chain]) {
        let mut seen = vec![false; m.set.len()];
        for c in chains {
            for &p in &c.pixels {
                seen[p as usize] = true;
            }
        }
        assert_eq!(seen, m.set);
    }

    #[test]
    fn staircase_is_one_chain() {
        let m = map(&["##....", ".##...", "..##..", "...##."]);
        let chains = trace(&m);
        assert_eq!(chains.len(), 1);
        assert_eq!(chains[0].pixels.len(), 8);
        all_pixels_covered(&m, &chains);
    }

    #[test]
    fn loop_is_closed() {
        let m = map(&[".###.", "#...#", "#...#", ".###."]);
        let chains = trace(&m);
        assert_eq!(chains.len(), 1);
        let c = &chains[0].pixels;
        assert_eq!(c.first(), c.last());
        assert_eq!(c.len(), 11);
    }

    #[test]
    fn fork_splits_and_stays_connected() {
        let m = map(&["#####", "..#..", "..#..", "..#.."]);
        let chains = trace(&m);
        assert_eq!(chains.len(), 3);
        all_pixels_covered(&m, &chains);
        // Every chain touches the fork pixel (2, 0).
        for c in &chains {
            assert!(c.pixels.contains(&2), "{:?}", c.pixels);
        }
        assert!(is_fork(&m, 2));
    }

    #[test]
    fn thick_line_thinned_to_one_chain() {
        let mut m = map(&["..........", ".########.", ".########.", ".........."]);
        thin(&mut m);
        assert_eq!(m.set.iter().filter(|&&s| s).count(), 8);
        let chains = trace(&m);
        assert_eq!(chains.len(), 1);
        assert_eq!(chains[0].pixels.len(), 8);
    }

    #[test]
    fn thin_keeps_thin_curves() {
        let rows = ["##....", ".##...", "..##..", "...##.", "....#."];
        let mut m = map(&rows);
        let before = m.set.clone();
        thin(&mut m);
        // Staircase corners may go, but the curve stays connected and keeps
        // its ends.
        assert_eq!(trace(&m).len(), 1);
        assert!(m.set[0] && m.set[4 * 6 + 4]);
        assert!(m.set.iter().zip(&before).all(|(a, b)| !a || *b));
    }

    #[test]
    fn components() {
        let m = map(&["##..#", "....#", "#...#"]);
        let s = component_sizes(&m);
        assert_eq!(s[0], 2);
        assert_eq!(s[4], 3);
        assert_eq!(s[10], 1);
        assert_eq!(s[2], 0);
    }
}

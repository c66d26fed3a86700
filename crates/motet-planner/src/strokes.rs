//! Turning machine-space polylines into pen commands.
//!
//! Job sources that draw (SVG, traced images) hand [`StrokeEmitter`] one
//! polyline at a time in the plane of two machine axes. It lifts the pen
//! before travel unless it is already up, travels to the polyline's start,
//! lowers the pen with the tool's on value, feeds along the polyline at the
//! draw feed and drops moves shorter than [`SAME_POINT`]. It keeps track of
//! the position, the pen and how far it drew and travelled.

use motet_trajectory::Point;

use crate::command::{Command, Located, Move, MoveKind, SourceLoc};
use crate::target::JobTarget;

/// Points closer than this (mm) count as the same point.
pub const SAME_POINT: f64 = 1e-9;

/// Whether `a` and `b` are within [`SAME_POINT`] of each other.
pub fn same_point(a: [f64; 2], b: [f64; 2]) -> bool {
    (a[0] - b[0]).hypot(a[1] - b[1]) <= SAME_POINT
}

/// `pts` without points that are the same as the point kept before them.
pub fn dedup_points(pts: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let mut clean: Vec<[f64; 2]> = Vec::with_capacity(pts.len());
    for &p in pts {
        if clean.last().is_none_or(|&q| !same_point(p, q)) {
            clean.push(p);
        }
    }
    clean
}

/// How a [`StrokeEmitter`] draws.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StrokeSettings {
    /// Where the machine is when drawing starts (every axis).
    pub start: Point,
    /// Machine axis index of the drawing's x.
    pub xi: usize,
    /// Machine axis index of the drawing's y.
    pub yi: usize,
    /// Tool index and its "on" value; `None` emits no tool commands.
    pub tool: Option<(u8, f32)>,
    /// Feed along polylines, units/s.
    pub draw_feed: f64,
    /// Feed of pen-up travel, units/s (`f64::INFINITY` for rapids).
    pub travel_feed: f64,
    /// Kind of pen-up travel moves.
    pub travel_kind: MoveKind,
}

impl StrokeSettings {
    /// Settings for `target` drawing in axes `xi`, `yi`: from its start, with
    /// its primary tool at its on value and its draw feed, travelling in
    /// rapids.
    pub fn for_target(target: &JobTarget, xi: usize, yi: usize) -> Self {
        StrokeSettings {
            start: target.start,
            xi,
            yi,
            tool: target
                .primary_tool()
                .map(|t| (t, target.tools[t as usize].on_value)),
            draw_feed: target.draw_feed,
            travel_feed: f64::INFINITY,
            travel_kind: MoveKind::Rapid,
        }
    }

    /// Travel at `feed` units/s when it is a positive finite number, in
    /// rapids otherwise.
    pub fn with_travel_feed(mut self, feed: f64) -> Self {
        (self.travel_feed, self.travel_kind) = if feed.is_finite() && feed > 0.0 {
            (feed, MoveKind::Feed)
        } else {
            (f64::INFINITY, MoveKind::Rapid)
        };
        self
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Pen {
    Unknown,
    Up,
    Down,
}

/// Turns machine-space polylines into commands, tracking pen and position.
#[derive(Clone, Debug)]
pub struct StrokeEmitter {
    settings: StrokeSettings,
    out: Vec<Located<Command>>,
    pos: Point,
    pen: Pen,
    drawn: f64,
    travel: f64,
}

impl StrokeEmitter {
    /// An emitter at `settings.start` that does not know where the pen is
    /// (the first lift or lowering is always emitted).
    pub fn new(settings: StrokeSettings) -> Self {
        StrokeEmitter {
            settings,
            out: Vec::new(),
            pos: settings.start,
            pen: Pen::Unknown,
            drawn: 0.0,
            travel: 0.0,
        }
    }

    /// The settings it was made with.
    pub fn settings(&self) -> &StrokeSettings {
        &self.settings
    }

    /// Where the machine is after the commands so far (every axis).
    pub fn position(&self) -> Point {
        self.pos
    }

    /// Position in the drawing plane.
    pub fn xy(&self) -> [f64; 2] {
        [self.pos[self.settings.xi], self.pos[self.settings.yi]]
    }

    /// Pen-down length so far.
    pub fn drawn(&self) -> f64 {
        self.drawn
    }

    /// Pen-up travel so far (from the start).
    pub fn travel(&self) -> f64 {
        self.travel
    }

    /// The commands so far.
    pub fn commands(&self) -> &[Located<Command>] {
        &self.out
    }

    /// Append any command (a pause between pens, say) at `loc`.
    pub fn push(&mut self, loc: SourceLoc, item: Command) {
        self.out.push(Located { loc, item });
    }

    /// Move in the plane; returns the move's length.
    fn move_to(&mut self, p: [f64; 2], feed: f64, kind: MoveKind, loc: SourceLoc) -> f64 {
        let (xi, yi) = (self.settings.xi, self.settings.yi);
        let len = (p[0] - self.pos[xi]).hypot(p[1] - self.pos[yi]);
        let mut target = self.pos;
        target[xi] = p[0];
        target[yi] = p[1];
        self.pos = target;
        self.push(loc, Command::Move(Move { target, feed, kind }));
        len
    }

    fn set_pen(&mut self, want: Pen, loc: SourceLoc) {
        if self.pen == want {
            return;
        }
        self.pen = want;
        if let Some((tool, on)) = self.settings.tool {
            let value = if want == Pen::Down { on } else { 0.0 };
            self.push(loc, Command::Tool { tool, value });
        }
    }

    /// Lift the pen unless it is already up.
    pub fn lift(&mut self, loc: SourceLoc) {
        self.set_pen(Pen::Up, loc);
    }

    /// Travel pen up to `p` unless already there (then nothing is emitted).
    pub fn travel_to(&mut self, p: [f64; 2], loc: SourceLoc) {
        if same_point(self.xy(), p) {
            return;
        }
        self.lift(loc);
        let (feed, kind) = (self.settings.travel_feed, self.settings.travel_kind);
        self.travel += self.move_to(p, feed, kind, loc);
    }

    /// Draw `pts`: travel to its start unless already there, lower the pen
    /// and feed along it, leaving out points the same as the one before.
    /// Returns false, emitting nothing, if fewer than two distinct points
    /// are left.
    pub fn polyline(&mut self, pts: &[[f64; 2]], loc: SourceLoc) -> bool {
        let clean = dedup_points(pts);
        if clean.len() < 2 {
            return false;
        }
        self.travel_to(clean[0], loc);
        self.set_pen(Pen::Down, loc);
        for &p in &clean[1..] {
            self.drawn += self.move_to(p, self.settings.draw_feed, MoveKind::Feed, loc);
        }
        true
    }

    /// The commands, ending with the pen lifted if anything was emitted.
    pub fn finish(mut self, loc: SourceLoc) -> Vec<Located<Command>> {
        if !self.out.is_empty() {
            self.lift(loc);
        }
        self.out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::target::{AxisInfo, ToolInfo, ToolKind};

    const L: SourceLoc = SourceLoc { line: 3, column: 7 };

    fn settings() -> StrokeSettings {
        StrokeSettings {
            start: [5.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            xi: 0,
            yi: 1,
            tool: Some((0, 0.75)),
            draw_feed: 20.0,
            travel_feed: f64::INFINITY,
            travel_kind: MoveKind::Rapid,
        }
    }

    fn moves(cmds: &[Located<Command>]) -> Vec<Move> {
        cmds.iter()
            .filter_map(|c| match c.item {
                Command::Move(m) => Some(m),
                _ => None,
            })
            .collect()
    }

    /// 'U'/'D' for tool commands, 'T' for travel, 'F' for feed moves.
    fn shape(cmds: &[Located<Command>]) -> String {
        cmds.iter()
            .map(|c| match c.item {
                Command::Tool { value: 0.0, .. } => 'U',
                Command::Tool { .. } => 'D',
                Command::Move(Move {
                    kind: MoveKind::Feed,
                    feed: 20.0,
                    ..
                }) => 'F',
                Command::Move(_) => 'T',
                Command::Pause { .. } => 'P',
                _ => '?',
            })
            .collect()
    }

    #[test]
    fn pen_sequence() {
        let mut em = StrokeEmitter::new(settings());
        assert!(em.polyline(&[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]], L));
        // Starts where the last one ended: no lift, no travel.
        assert!(em.polyline(&[[1.0, 1.0], [2.0, 1.0]], L));
        assert!(em.polyline(&[[0.0, 5.0], [0.0, 6.0]], L));
        let cmds = em.finish(SourceLoc::default());
        assert_eq!(shape(&cmds), "UTDFFFUTDFU");
        let tools: Vec<f32> = cmds
            .iter()
            .filter_map(|c| match c.item {
                Command::Tool { tool: 0, value } => Some(value),
                _ => None,
            })
            .collect();
        assert_eq!(tools, [0.0, 0.75, 0.0, 0.75, 0.0]);
        assert!(cmds[..cmds.len() - 1].iter().all(|c| c.loc == L));
        assert_eq!(cmds.last().unwrap().loc, SourceLoc::default());
    }

    #[test]
    fn starting_at_the_start_only_lowers() {
        let mut em = StrokeEmitter::new(settings());
        em.polyline(&[[5.0, 0.0], [6.0, 0.0]], L);
        assert_eq!(shape(&em.finish(L)), "DFU");
    }

    #[test]
    fn no_zero_length_moves() {
        let mut em = StrokeEmitter::new(settings());
        let d = SAME_POINT / 4.0;
        assert!(!em.polyline(&[[1.0, 1.0], [1.0 + d, 1.0], [1.0, 1.0 + d]], L));
        assert!(!em.polyline(&[[2.0, 2.0]], L));
        assert!(!em.polyline(&[], L));
        assert!(em.commands().is_empty());
        assert!(em.polyline(&[[5.0 + d, 0.0], [5.0, 1.0], [5.0, 1.0], [5.0, 1.0 + d]], L));
        em.travel_to([5.0, 1.0 + d], L);
        let cmds = em.finish(L);
        assert_eq!(shape(&cmds), "DFU");
        let ms = moves(&cmds);
        let mut prev = [5.0, 0.0];
        for m in ms {
            let p = [m.target[0], m.target[1]];
            assert!(!same_point(prev, p));
            prev = p;
        }
        // Finishing with nothing emitted emits nothing.
        assert!(StrokeEmitter::new(settings()).finish(L).is_empty());
    }

    #[test]
    fn distances_and_position() {
        let mut s = settings();
        s.start = [0.0, 0.0, 9.0, 0.0, 0.0, 0.0];
        s.xi = 1;
        s.yi = 3;
        let mut em = StrokeEmitter::new(s);
        em.polyline(&[[3.0, 4.0], [3.0, 6.0], [6.0, 10.0]], L);
        em.travel_to([6.0, 12.0], L);
        em.polyline(&[[6.0, 12.0], [7.0, 12.0]], L);
        assert!((em.drawn() - 8.0).abs() < 1e-12);
        assert!((em.travel() - 7.0).abs() < 1e-12);
        assert_eq!(em.xy(), [7.0, 12.0]);
        assert_eq!(em.position(), [0.0, 7.0, 9.0, 12.0, 0.0, 0.0]);
        // Other axes stay where they started.
        for m in moves(em.commands()) {
            assert_eq!((m.target[0], m.target[2]), (0.0, 9.0));
        }
    }

    #[test]
    fn travel_feed_finite_vs_rapid() {
        let finite = settings().with_travel_feed(50.0);
        assert_eq!(
            (finite.travel_feed, finite.travel_kind),
            (50.0, MoveKind::Feed)
        );
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let s = settings().with_travel_feed(bad);
            assert_eq!(s.travel_kind, MoveKind::Rapid);
            assert_eq!(s.travel_feed, f64::INFINITY);
        }
        let mut em = StrokeEmitter::new(finite);
        em.polyline(&[[0.0, 0.0], [1.0, 0.0]], L);
        let ms = moves(em.commands());
        assert_eq!((ms[0].feed, ms[0].kind), (50.0, MoveKind::Feed));
        assert_eq!((ms[1].feed, ms[1].kind), (20.0, MoveKind::Feed));

        let mut em = StrokeEmitter::new(settings());
        em.polyline(&[[0.0, 0.0], [1.0, 0.0]], L);
        let ms = moves(em.commands());
        assert_eq!(ms[0].kind, MoveKind::Rapid);
        assert!(ms[0].feed.is_infinite());
    }

    #[test]
    fn no_tool_emits_only_moves() {
        let mut s = settings();
        s.tool = None;
        let mut em = StrokeEmitter::new(s);
        em.polyline(&[[0.0, 0.0], [1.0, 0.0]], L);
        em.lift(L);
        em.polyline(&[[2.0, 0.0], [3.0, 0.0]], L);
        let cmds = em.finish(L);
        assert_eq!(shape(&cmds), "TFTF");
    }

    #[test]
    fn lift_and_pause_between_pens() {
        let mut em = StrokeEmitter::new(settings());
        em.polyline(&[[0.0, 0.0], [1.0, 0.0]], L);
        em.lift(L);
        em.lift(L);
        em.travel_to([1.0, 0.0], L);
        em.push(L, Command::Pause { optional: false });
        em.polyline(&[[1.0, 0.0], [2.0, 0.0]], L);
        assert_eq!(shape(&em.finish(L)), "UTDFUPDFU");
    }

    #[test]
    fn for_target_uses_primary_tool_and_draw_feed() {
        let axis = |n: &str| AxisInfo {
            name: n.into(),
            travel: [0.0, 100.0],
            path: true,
        };
        let mut target = JobTarget {
            axes: vec![axis("x"), axis("y")],
            tools: vec![ToolInfo {
                name: "pen".into(),
                kind: ToolKind::Pen,
                on_value: 0.5,
            }],
            start: [1.0, 2.0, 0.0, 0.0, 0.0, 0.0],
            tolerance: 0.01,
            draw_feed: 33.0,
        };
        let s = StrokeSettings::for_target(&target, 0, 1);
        assert_eq!(s.tool, Some((0, 0.5)));
        assert_eq!(s.draw_feed, 33.0);
        assert_eq!(s.start, target.start);
        assert_eq!(s.travel_kind, MoveKind::Rapid);
        target.tools.clear();
        assert_eq!(StrokeSettings::for_target(&target, 0, 1).tool, None);
    }
}

//! The node application's main loop, the same on every board.
//!
//! Each round: received bytes become frames for the endpoint; the board's
//! inputs go to the graph; the node runs ahead of now by the lookahead, in
//! short slices while the step queue has room, each output converted to
//! ticks and queued for the step interrupt; replies are sent; the LED and
//! button serve pairing; a started upload restarts into the bootloader.
//! Then the loop sleeps until an interrupt or its next deadline: every
//! `refill_us` while motion is queued, so the queue always holds at least
//! `lookahead_us − refill_us` of motion.

use crate::board::{Board, Inputs};
use crate::boot;
use crate::clock::{Clock, HostToTicks};
use crate::frames::{take_frames, FrameReader};
use crate::interrupt::Counters;
use crate::ring::Producer;
use crate::schedule::{Scheduler, Timing};
use crate::staging::Staging;
use crate::store::FlashStore;
use motet_node::endpoint::Endpoint;
use motet_node::service::NodeConfig;
use motet_node::DEFAULT_QUEUE;
use motet_wire::frame::MAX_FRAME;
use motet_wire::link::PROTOCOL_VERSION;
use motet_wire::message::GraphInputKind;
use motet_wire::service::{Kind, Version};
use motet_wire::sync::ClockModel;

/// What a board's `main` tells the application.
#[derive(Clone, Copy, Debug)]
pub struct AppConfig {
    /// Node kind (`motet_wire::service::kind`).
    pub kind: &'static str,
    pub version: Version,
    /// How far ahead of now the node runs, µs.
    pub lookahead_us: u32,
    /// How often the loop refills the queue while motion is queued, µs.
    pub refill_us: u32,
    /// How far one slice runs the node, µs (bounds what one slice queues).
    pub slice_us: u32,
    /// Diagnostics on the board's console every this many µs (0: never).
    pub report_us: u32,
}

impl AppConfig {
    pub const fn new(kind: &'static str, version: Version) -> AppConfig {
        AppConfig {
            kind,
            version,
            lookahead_us: 4000,
            refill_us: 1000,
            slice_us: 250,
            report_us: 2_000_000,
        }
    }
}

/// An idle node wakes at least this often (link timeouts come sooner).
const IDLE_US: u64 = 50_000;

/// Runs the node on `board` for ever. `queue` is the producer half of the
/// step queue whose consumer the board's step interrupt runs, `counters`
/// what that interrupt counts.
pub fn run<B: Board>(
    mut board: B,
    queue: Producer<'static>,
    counters: &'static Counters,
    cfg: AppConfig,
) -> ! {
    let tpu = B::TICKS_PER_US;
    let layout = B::LAYOUT;
    let mut clock = Clock::new(board.ticks(), tpu);
    let now = clock.us(board.ticks());
    let store = FlashStore::new(board.flash(), layout.identity, cfg.version);
    let staging = Staging::new(board.flash(), layout.staging);
    let mut ep: Endpoint<_, _, DEFAULT_QUEUE> =
        Endpoint::new(node_config(&board, &cfg), store, staging, now);
    // Without a floating-point unit, steps in fixed-point time.
    ep.node_mut().use_fixed_time(B::FIXED_TIME_US);
    // It describes itself by its channels (port 8) and says it is here.
    ep.announce();
    board.console(format_args!(
        "motet: {} node on {}, firmware {}, uid {:016x}, address {} (endpoint {} bytes)",
        cfg.kind,
        B::NAME,
        cfg.version,
        ep.services().uid(),
        ep.services().address(),
        core::mem::size_of_val(&ep),
    ));
    let mut sched = Scheduler::new(queue, tpu);
    let ahead = RunAhead::new::<B>(&cfg);
    let mut reader = FrameReader::new();
    let mut polled = now;
    let mut inputs = Inputs::default();
    let mut fed = Inputs::default();
    let mut button = false;
    let mut next_report = now + cfg.report_us as u64;
    let mut rx = [0u8; 64];
    let mut tx = [0u8; MAX_FRAME];
    let mut loop_stats = LoopStats::default();
    let mut last_round = now;
    loop {
        let start = clock.us(board.ticks());
        loop_stats.rounds += 1;
        loop_stats.max_gap_us = loop_stats.max_gap_us.max(start - last_round);
        last_round = start;
        // The rest of the round runs at the last frame's time: never
        // before a time the endpoint has seen.
        let now = receive(&mut board, &mut reader, &mut rx, &mut ep, &mut clock).max(start);
        follow_channel_timing(&ep, &mut sched, tpu);

        board.read_inputs(&mut inputs);
        if inputs != fed {
            feed_inputs(ep.node_mut(), &inputs, &fed);
            fed = inputs;
        }

        let queued_before = sched.queued();
        polled = ahead.run(&mut ep, &mut sched, &clock, polled, now);
        if sched.queued() != queued_before {
            board.kick_steps();
        }

        send_replies(&mut board, &mut ep, now, &mut tx);
        board.set_led(ep.services().blinking(now));
        let pressed = board.button();
        if pressed && !button {
            ep.press_button(now);
            send_replies(&mut board, &mut ep, now, &mut tx);
        }
        button = pressed;

        if ep.start_requested() {
            // The acknowledgement has left; the bootloader installs the
            // staged image (it checks it again) and starts it.
            board.link_flush();
            let mut f = board.flash();
            let _ = boot::request_install(&mut f, &layout);
            board.restart();
        }

        if cfg.report_us > 0 && now >= next_report {
            next_report = now + cfg.report_us as u64;
            report(&mut board, &ep, &sched, counters, &loop_stats);
            loop_stats = LoopStats::default();
        }
        let spent = clock.us(board.ticks()) - now;
        loop_stats.max_round_us = loop_stats.max_round_us.max(spent);

        let wake = next_wake(&mut ep, &sched, &cfg, now);
        if wake > now {
            board.sleep_until(clock.tick_at(wake));
        }
    }
}

/// What the node says of itself: the board's identity and capacities, the
/// firmware's version and kind.
fn node_config<B: Board>(board: &B, cfg: &AppConfig) -> NodeConfig {
    NodeConfig {
        kind: Kind::try_from(cfg.kind).unwrap_or_default(),
        uid: board.uid(),
        firmware: cfg.version,
        protocol_min: PROTOCOL_VERSION,
        protocol_max: PROTOCOL_VERSION,
        queue_capacity: DEFAULT_QUEUE as u16,
        channels: B::CHANNELS,
        tools: B::TOOLS,
        board: Kind::try_from(B::NAME).ok(),
        max_step_hz: B::MAX_STEP_HZ,
    }
}

/// Hands each frame the link received to the endpoint, at the clock's
/// time when it was taken ([`take_frames`]); returns the last such time.
fn receive<B: Board, S, F, const Q: usize>(
    board: &mut B,
    reader: &mut FrameReader,
    rx: &mut [u8],
    ep: &mut Endpoint<S, F, Q>,
    clock: &mut Clock,
) -> u64
where
    S: motet_node::Store,
    F: motet_node::Flash,
{
    // The board is read for its bytes and its counter in turn.
    let board = core::cell::RefCell::new(board);
    take_frames(
        reader,
        rx,
        |buf| board.borrow_mut().link_read(buf),
        || clock.us(board.borrow().ticks()),
        |f, now| ep.on_frame(f, now),
    )
}

/// Channel timing follows the host's configuration (only taken at rest: a
/// channel is configured with an empty queue).
fn follow_channel_timing<S, F, const Q: usize>(
    ep: &Endpoint<S, F, Q>,
    sched: &mut Scheduler<'_>,
    tpu: u32,
) where
    S: motet_node::Store,
    F: motet_node::Flash,
{
    for ch in ep.node().channels() {
        let c = ch.config();
        let t = Timing::from_us(c.pulse_us, c.dir_setup_us, tpu);
        if sched.timing(c.channel) != Some(t) {
            sched.set_timing(c.channel, c.pulse_us, c.dir_setup_us);
        }
    }
}

/// How the node runs ahead of now, from the configuration and the board.
#[derive(Clone, Copy, Debug)]
struct RunAhead {
    /// How far ahead of now, µs.
    lookahead_us: u64,
    /// How far one slice runs the node, µs.
    slice_us: u64,
    /// Room the step queue must have before a slice runs.
    reserve: usize,
    ticks_per_us: u32,
}

impl RunAhead {
    fn new<B: Board>(cfg: &AppConfig) -> RunAhead {
        RunAhead {
            lookahead_us: cfg.lookahead_us as u64,
            slice_us: cfg.slice_us as u64,
            // What one slice can queue at the board's top rate: three
            // operations a step on every channel, a few tool changes.
            reserve: (B::CHANNELS as u64 * B::MAX_STEP_HZ as u64 * cfg.slice_us as u64 * 3
                / 1_000_000) as usize
                + 16,
            ticks_per_us: B::TICKS_PER_US,
        }
    }

    /// Runs the node from `polled` (µs, how far it has run) towards the
    /// lookahead past `now`, a slice at a time while the step queue has
    /// room, its outputs queued at ticks of the host's clock model; returns
    /// how far it ran. Without a clock model the node does not move.
    fn run<S, F, const Q: usize>(
        &self,
        ep: &mut Endpoint<S, F, Q>,
        sched: &mut Scheduler<'_>,
        clock: &Clock,
        mut polled: u64,
        now: u64,
    ) -> u64
    where
        S: motet_node::Store,
        F: motet_node::Flash,
    {
        if let Some(model) = ep.services().clock_model() {
            // (Without an FPU, outputs near now turn into ticks in integers.)
            let conv = HostToTicks::new(model, self.ticks_per_us).near(model.host(now as f64));
            let target = now + self.lookahead_us;
            // Behind (a long frame, a slow flash write): what is due now is
            // queued at once and leaves late, nothing is skipped.
            polled = polled.max(now);
            while polled < target && sched.room() >= self.reserve {
                polled = (polled + self.slice_us).min(target);
                ep.poll(polled, &mut sched.outputs(conv));
                sched.release(clock.tick_at(polled));
            }
            polled
        } else {
            let none = HostToTicks::new(
                ClockModel {
                    offset: 0.0,
                    skew: 0.0,
                },
                self.ticks_per_us,
            );
            // Not synchronised: the node does not run (the endpoint knows).
            ep.poll(now, &mut sched.outputs(none));
            now
        }
    }
}

/// Sends every frame the endpoint has to send.
fn send_replies<B: Board, S, F, const Q: usize>(
    board: &mut B,
    ep: &mut Endpoint<S, F, Q>,
    now: u64,
    tx: &mut [u8],
) where
    S: motet_node::Store,
    F: motet_node::Flash,
{
    while let Some(f) = ep.transmit(now, tx) {
        board.link_write(f);
    }
}

/// When the loop next wakes, µs: a refill period ahead while motion is
/// queued or a graph runs, else the idle period or the endpoint's next
/// deadline, whichever is sooner; never past the link's next timeout.
fn next_wake<S, F, const Q: usize>(
    ep: &mut Endpoint<S, F, Q>,
    sched: &Scheduler<'_>,
    cfg: &AppConfig,
    now: u64,
) -> u64
where
    S: motet_node::Store,
    F: motet_node::Flash,
{
    let busy = ep.node().queued() > 0
        || ep.node().graph().is_some()
        || sched.held() > 0
        || sched.queued() > 0;
    let mut wake = now + if busy { cfg.refill_us as u64 } else { IDLE_US };
    if let Some(w) = ep.next_wakeup(now) {
        if !busy {
            wake = wake.min(w);
        }
    }
    if let Some(l) = ep.link().and_then(|l| l.next_timeout()) {
        wake = wake.min(l);
    }
    wake
}

/// How the loop keeps up, between two reports.
#[derive(Clone, Copy, Debug, Default)]
struct LoopStats {
    rounds: u32,
    /// Longest round's work, µs.
    max_round_us: u64,
    /// Longest time between two rounds' starts, µs.
    max_gap_us: u64,
}

/// Gives the node's graph the inputs that changed.
fn feed_inputs<const Q: usize>(node: &mut motet_node::Node<Q>, now: &Inputs, before: &Inputs) {
    for i in 0..now.encoders.len() {
        if now.encoders[i] != before.encoders[i] {
            let _ = node.set_input(GraphInputKind::Encoder, i as u8, now.encoders[i] as f64);
        }
        if now.analog[i] != before.analog[i] {
            let _ = node.set_input(GraphInputKind::Analog, i as u8, now.analog[i] as f64);
        }
        if now.digital[i] != before.digital[i] {
            let v = if now.digital[i] { 1.0 } else { 0.0 };
            let _ = node.set_input(GraphInputKind::Digital, i as u8, v);
        }
    }
}

/// One line of what the outputs did: the pins' pulses per channel (the
/// interrupt's count) beside the node's tally, late operations, delayed
/// steps, and what the step queue holds.
fn report<B: Board, S, F, const Q: usize>(
    board: &mut B,
    ep: &Endpoint<S, F, Q>,
    sched: &Scheduler<'_>,
    counters: &Counters,
    rounds: &LoopStats,
) where
    S: motet_node::Store,
    F: motet_node::Flash,
{
    use core::sync::atomic::Ordering::Relaxed;
    let p = counters.pulses();
    let t = ep.node().tally().map(|t| t.steps).unwrap_or_default();
    let st = sched.stats();
    board.console(format_args!(
        "motet: pulses {:?} tally {:?} tools {} late {} (max {} ticks) delayed {} (max {} ticks) lost {} queued {} state {:?} rounds {} (longest {} us, gap {} us)",
        p,
        t,
        counters.tool_changes.load(Relaxed),
        counters.late.load(Relaxed),
        counters.max_late.load(Relaxed),
        st.delayed,
        st.max_delay,
        st.lost,
        sched.queued(),
        ep.services().state(),
        rounds.rounds,
        rounds.max_round_us,
        rounds.max_gap_us,
    ));
}

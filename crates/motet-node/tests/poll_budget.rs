//! One poll hands out at most `MAX_OUTPUTS_PER_POLL` outputs: a poll with
//! more due stops at the last one's time, and polling on gives exactly the
//! outputs of a node polled in small steps.

use crate::common;

use common::*;
use motet_node::{Node, MAX_OUTPUTS_PER_POLL};
use motet_trajectory::ProfileKind;

/// Everything `node` does when polled again and again up to `until`; the
/// outputs of each poll, in order.
fn poll_to<const Q: usize>(node: &mut Node<Q>, until: f64) -> Vec<Vec<Out>> {
    let mut polls = Vec::new();
    while node.time() < until {
        let mut rec = Recorder::default();
        node.poll(until, &mut rec);
        polls.push(rec.out);
    }
    polls
}

#[test]
fn a_poll_stops_after_its_budget_and_the_next_goes_on() {
    for machine in [cartesian(), corexy(), polar()] {
        let cmds = [
            feed(2000.0, 1500.0, 1.0, 6000.0),
            feed(100.0, 20.0, 5.0, 6000.0),
        ];
        let planned = plan(limits(ProfileKind::SCurve), START, &cmds);
        let mut msgs = machine.setup();
        msgs.extend(machine.stream(&planned));
        let end = segments(&planned).last().unwrap().t1() + 1.0;

        // All at once: one poll to past the end, repeated.
        let mut node = Node::<64>::new();
        node.keep_tally();
        for m in &msgs {
            assert_eq!(send(&mut node, m), None, "{}", machine.name);
        }
        let polls = poll_to(&mut node, end);
        let total: usize = polls.iter().map(Vec::len).sum();
        assert!(
            total > 2 * MAX_OUTPUTS_PER_POLL as usize,
            "{}: the job needs several polls ({total} outputs)",
            machine.name
        );
        for (k, p) in polls.iter().enumerate() {
            assert!(p.len() <= MAX_OUTPUTS_PER_POLL as usize, "{}", machine.name);
            if k + 1 < polls.len() {
                assert_eq!(p.len(), MAX_OUTPUTS_PER_POLL as usize, "{}", machine.name);
            }
        }
        assert_eq!(node.time(), end, "{}", machine.name);
        let whole: Vec<_> = polls.concat().iter().map(Out::key).collect();

        // The same job polled in small frames.
        let mut framed = Node::<64>::new();
        framed.keep_tally();
        for m in &msgs {
            assert_eq!(send(&mut framed, m), None);
        }
        let mut out = Vec::new();
        let mut t = 0.0;
        while t < end {
            t = (t + 500.0).min(end);
            let mut rec = Recorder::default();
            framed.poll(t, &mut rec);
            assert_eq!(framed.time(), t, "small frames are never cut short");
            out.extend(rec.out);
        }
        let framed_keys: Vec<_> = out.iter().map(Out::key).collect();
        assert_eq!(whole.len(), framed_keys.len(), "{}", machine.name);
        assert!(whole == framed_keys, "{}: same outputs", machine.name);
        assert_eq!(node.tally(), framed.tally(), "{}", machine.name);
        assert_eq!(node.status().underruns, 0, "{}", machine.name);
    }
}

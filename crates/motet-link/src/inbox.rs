//! The receive loop shared by transports that read a medium in pieces and
//! find frames in what they read (serial, slcan, the simulated CAN bus).
//!
//! Such a transport keeps an [`Inbox`] of frames completed but not yet handed
//! out. Its `recv` is one call to [`Inbox::recv`] with a function that reads
//! the medium once; the inbox decides how often to call it, how long each
//! read may wait, and counts what it hands out.

use crate::{LinkStats, StreamSplitter};
use std::collections::{BTreeMap, VecDeque};
use std::io;
use std::time::{Duration, Instant};

/// Frames received and not yet handed out, oldest first.
#[derive(Clone, Debug, Default)]
pub struct Inbox {
    ready: VecDeque<Vec<u8>>,
}

impl Inbox {
    /// An empty inbox.
    pub fn new() -> Inbox {
        Inbox::default()
    }

    /// Queues one complete frame.
    pub fn push(&mut self, frame: Vec<u8>) {
        self.ready.push_back(frame);
    }

    /// Feeds bytes of a stream through `splitter`, queueing every frame they
    /// complete.
    pub fn take_stream(&mut self, splitter: &mut StreamSplitter, bytes: &[u8]) {
        let ready = &mut self.ready;
        splitter.push(bytes, &mut |f| ready.push_back(f));
    }

    /// Feeds bytes from sender `from` through that sender's splitter, so
    /// that fragments of frames from several senders on one medium (a CAN
    /// bus) are joined per sender.
    pub fn take_from(
        &mut self,
        splitters: &mut BTreeMap<u32, StreamSplitter>,
        from: u32,
        bytes: &[u8],
    ) {
        self.take_stream(splitters.entry(from).or_default(), bytes);
    }

    /// Frames waiting.
    pub fn len(&self) -> usize {
        self.ready.len()
    }

    /// No frame is waiting to be handed out.
    pub fn is_empty(&self) -> bool {
        self.ready.is_empty()
    }

    /// The oldest frame waiting, counted in `stats`, without reading.
    pub fn pop(&mut self, stats: &mut LinkStats) -> Option<Vec<u8>> {
        let f = self.ready.pop_front();
        if let Some(f) = &f {
            stats.received(f.len());
        }
        f
    }

    /// [`Transport::recv`](crate::Transport::recv) for a transport that reads
    /// its medium with `read`: hands out the oldest frame waiting, reading
    /// first while none is.
    ///
    /// `read(inbox, wait)` reads the medium once, blocking at most `wait`
    /// (zero: not at all), queues the frames it completes and returns whether
    /// any bytes arrived. With `timeout` `None` the medium is read without
    /// waiting until it has nothing more; with `Some(d)` reads go on until a
    /// frame is complete or `d` has passed.
    pub fn recv(
        &mut self,
        timeout: Option<Duration>,
        stats: &mut LinkStats,
        mut read: impl FnMut(&mut Inbox, Duration) -> io::Result<bool>,
    ) -> io::Result<Option<Vec<u8>>> {
        let deadline = timeout.map(|d| Instant::now() + d);
        while self.ready.is_empty() {
            let wait = match deadline {
                None => Duration::ZERO,
                Some(t) => t.saturating_duration_since(Instant::now()),
            };
            let got = read(self, wait)?;
            if !got && (deadline.is_none() || wait.is_zero()) {
                break;
            }
        }
        Ok(self.pop(stats))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reads `chunks` one per call; returns the frames handed out per `recv`
    /// and how many reads were made.
    fn drain(chunks: &[&[u8]], timeout: Option<Duration>) -> (Vec<Option<Vec<u8>>>, usize) {
        let mut inbox = Inbox::new();
        let mut splitter = StreamSplitter::default();
        let mut stats = LinkStats::default();
        let mut next = 0;
        let mut out = Vec::new();
        for _ in 0..4 {
            let r = inbox.recv(timeout, &mut stats, |inbox, _wait| {
                let Some(c) = chunks.get(next) else {
                    return Ok(false);
                };
                next += 1;
                inbox.take_stream(&mut splitter, c);
                Ok(true)
            });
            out.push(r.unwrap());
        }
        assert_eq!(stats.frames_in as usize, out.iter().flatten().count());
        (out, next)
    }

    #[test]
    fn frames_across_reads_one_per_call() {
        // (chunks read, timeout, frames handed out by four calls, reads made)
        type Case<'a> = (
            &'a [&'a [u8]],
            Option<Duration>,
            Vec<Option<Vec<u8>>>,
            usize,
        );
        let ms = Some(Duration::from_millis(1));
        let cases: Vec<Case> = vec![
            (
                &[&[1, 0, 2, 0]],
                None,
                vec![Some(vec![1, 0]), Some(vec![2, 0]), None, None],
                1,
            ),
            (
                &[&[1], &[2], &[0]],
                None,
                vec![Some(vec![1, 2, 0]), None, None, None],
                3,
            ),
            (
                &[&[1], &[], &[0]],
                ms,
                vec![Some(vec![1, 0]), None, None, None],
                3,
            ),
            (&[], ms, vec![None, None, None, None], 0),
        ];
        for (chunks, timeout, want, reads) in cases {
            assert_eq!(drain(chunks, timeout), (want, reads), "{chunks:?}");
        }
    }

    #[test]
    fn fragments_joined_per_sender() {
        let mut inbox = Inbox::new();
        let mut splitters = BTreeMap::new();
        inbox.take_from(&mut splitters, 1, &[1, 1]);
        inbox.take_from(&mut splitters, 2, &[2, 0]);
        inbox.take_from(&mut splitters, 1, &[1, 0]);
        let mut stats = LinkStats::default();
        assert_eq!(inbox.len(), 2);
        assert_eq!(inbox.pop(&mut stats), Some(vec![2, 0]));
        assert_eq!(inbox.pop(&mut stats), Some(vec![1, 1, 1, 0]));
        assert!(inbox.is_empty());
        assert_eq!(stats.bytes_in, 6);
    }
}

//! The per-cut records a machine has not yet handed to the MQTT client: a cut that finds
//! rumqttc's request queue full (broker down for long, a slow network) waits here and is
//! handed on, oldest first, as soon as the queue takes it (a period that finds the queue
//! full is dropped and counted instead). rumqttc resends a cut it had sent but not seen
//! acknowledged after the reconnection. Together: a machine that reconnects loses no cut,
//! up to [`CUT_OUTBOX`] cuts waiting.

use std::collections::VecDeque;

/// Cuts that may wait for the broker (at one cut a minute, more than two days).
pub const CUT_OUTBOX: usize = 4096;

/// Cuts waiting for room in the client's request queue, oldest first.
#[derive(Debug, Default)]
pub struct CutOutbox {
    waiting: VecDeque<Vec<u8>>,
    /// Cuts dropped because the outbox was full (the oldest goes first).
    pub overflowed: u64,
}

impl CutOutbox {
    /// Add one cut's message body at the back (dropping the oldest when full).
    pub fn push(&mut self, body: Vec<u8>) {
        if self.waiting.len() >= CUT_OUTBOX {
            self.waiting.pop_front();
            self.overflowed += 1;
        }
        self.waiting.push_back(body);
    }

    /// Hand the waiting cuts to `send`, oldest first, until it refuses one (that one stays
    /// at the front). Returns how many were handed on.
    pub fn flush(&mut self, mut send: impl FnMut(Vec<u8>) -> Result<(), Vec<u8>>) -> usize {
        let mut sent = 0;
        while let Some(body) = self.waiting.pop_front() {
            match send(body) {
                Ok(()) => sent += 1,
                Err(body) => {
                    self.waiting.push_front(body);
                    break;
                }
            }
        }
        sent
    }

    /// Cuts waiting.
    pub fn len(&self) -> usize {
        self.waiting.len()
    }

    /// No cut waiting.
    pub fn is_empty(&self) -> bool {
        self.waiting.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_refused_cut_stays_first_and_order_is_kept() {
        let mut o = CutOutbox::default();
        for i in 0..5u8 {
            o.push(vec![i]);
        }
        let mut got = Vec::new();
        let mut room = 2;
        let sent = o.flush(|b| {
            if room == 0 {
                return Err(b);
            }
            room -= 1;
            got.push(b[0]);
            Ok(())
        });
        assert_eq!((sent, o.len()), (2, 3));
        let sent = o.flush(|b| {
            got.push(b[0]);
            Ok(())
        });
        assert_eq!((sent, o.len()), (3, 0));
        assert_eq!(got, [0, 1, 2, 3, 4]);
    }

    #[test]
    fn a_full_outbox_drops_the_oldest_and_counts_it() {
        let mut o = CutOutbox::default();
        for i in 0..=CUT_OUTBOX {
            o.push(i.to_le_bytes().to_vec());
        }
        assert_eq!((o.len(), o.overflowed), (CUT_OUTBOX, 1));
        let mut first = None;
        o.flush(|b| {
            first.get_or_insert(b);
            Ok(())
        });
        assert_eq!(
            first,
            Some(1usize.to_le_bytes().to_vec()),
            "cut 0 was dropped"
        );
    }
}

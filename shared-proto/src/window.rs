//! One lane's sliding window: the sending half ([`SendLane`]) and the
//! receiving half ([`RecvLane`]).
//!
//! Sequence numbers are `u16` and wrap; they are compared by wrapping
//! difference, which is sound because a sender never has more than 255
//! frames in flight (its queue, `Endpoint`'s capacities).
//!
//! * The receiver delivers in order. A frame below `expected` is a duplicate
//!   (dropped, re-acknowledged); a frame inside the window but beyond
//!   `expected` is parked in a slot until the gap fills (and a NAK hint is
//!   sent); a frame beyond the window is a credit violation (dropped, counted).
//! * The window (credit) is what the receiver can take after `ack`, in the
//!   units each message is charged ([`crate::Wire::charge`]): free slots of its
//!   delivery queue ([`RecvLane`]), or free bytes of the board's line ring
//!   ([`DirectLane`]). A credit once advertised stays valid, because the
//!   receiver's free room only shrinks by accepting the frames it allowed and
//!   grows as the application takes messages; so the sender keeps the largest
//!   credit seen for its oldest unacknowledged frame, and stale or reordered
//!   advertisements are harmless.
//! * The sender keeps every unacknowledged message with the time it was last
//!   sent and retransmits each one `rto` after its last transmission (oldest
//!   first). A NAK for its oldest frame makes that frame due at once, at most
//!   once per `rto / 4`.

use heapless::Deque;

/// Wrapping "a is before b".
#[inline]
pub(crate) fn seq_before(a: u16, b: u16) -> bool {
    (a.wrapping_sub(b) as i16) < 0
}

struct Slot<T> {
    msg: T,
    sent_at: u32,
    /// What the message costs of the peer's credit.
    charge: u16,
}

/// Sending half of a lane: up to `N` messages from the oldest unacknowledged.
pub struct SendLane<T, const N: usize> {
    q: Deque<Slot<T>, N>,
    /// Sequence number of `q[0]`.
    base: u16,
    /// Entries of `q` transmitted at least once (a prefix).
    sent: usize,
    /// Sum of the charges of the sent entries.
    sent_charge: u32,
    /// The peer accepts messages from `base` on whose charges add up to at most this.
    credit: u16,
    retransmits: u32,
}

impl<T, const N: usize> Default for SendLane<T, N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T, const N: usize> SendLane<T, N> {
    pub const fn new() -> Self {
        Self {
            q: Deque::new(),
            base: 0,
            sent: 0,
            sent_charge: 0,
            credit: 0,
            retransmits: 0,
        }
    }

    /// Queues a message costing `charge` of the peer's credit; gives it back when the lane is
    /// full.
    pub fn push(&mut self, msg: T, charge: u16) -> Result<(), T> {
        self.q
            .push_back(Slot {
                msg,
                sent_at: 0,
                charge,
            })
            .map_err(|s| s.msg)
    }

    /// Free places for [`push`](Self::push).
    pub fn free(&self) -> usize {
        N - self.q.len()
    }

    /// Messages queued (sent or not) and not yet acknowledged.
    pub fn len(&self) -> usize {
        self.q.len()
    }

    pub fn is_empty(&self) -> bool {
        self.q.is_empty()
    }

    /// Messages sent and waiting for an acknowledgement.
    pub fn in_flight(&self) -> usize {
        self.sent
    }

    /// Oldest unacknowledged sequence number.
    pub fn base(&self) -> u16 {
        self.base
    }

    /// Sequence number the next new message will get.
    pub fn next_seq(&self) -> u16 {
        self.base.wrapping_add(self.q.len() as u16)
    }

    /// The peer's credit from [`base`](Self::base) on.
    pub fn credit(&self) -> u16 {
        self.credit
    }

    /// Total retransmissions so far.
    pub fn retransmits(&self) -> u32 {
        self.retransmits
    }

    /// There are unsent messages but the peer's window is closed.
    pub fn blocked(&self) -> bool {
        self.q
            .get(self.sent)
            .is_some_and(|next| self.sent_charge + u32::from(next.charge) > u32::from(self.credit))
    }

    /// Applies a cumulative ack `ack` (next seq the peer expects) with credit
    /// `win`. Returns how many messages it acknowledged. Acks outside
    /// `base..=base+in_flight` are ignored.
    pub fn on_ack(&mut self, ack: u16, win: u16) -> usize {
        let d = ack.wrapping_sub(self.base) as usize;
        if d > self.sent {
            return 0;
        }
        for _ in 0..d {
            if let Some(s) = self.q.pop_front() {
                self.sent_charge -= u32::from(s.charge);
            }
        }
        self.sent -= d;
        self.base = ack;
        // A new oldest frame: its credit replaces the old one; the same one: the larger counts
        // (an older advertisement arriving late).
        if d > 0 || win > self.credit {
            self.credit = win;
        }
        d
    }

    /// Fast-retransmit hint: the peer still expects `ack` and saw later frames. The oldest
    /// frame falls due at once; with `go_back`, every frame in flight does (the peer dropped
    /// what came after the gap, [`DirectLane`]).
    pub fn on_nak(&mut self, ack: u16, now: u32, rto: u32, go_back: bool) {
        if ack != self.base || self.sent == 0 {
            return;
        }
        let holdoff = (rto / 4).max(1);
        if self
            .q
            .front()
            .is_some_and(|front| now.wrapping_sub(front.sent_at) >= holdoff)
        {
            let n = if go_back { self.sent } else { 1 };
            for s in self.q.iter_mut().take(n) {
                s.sent_at = now.wrapping_sub(rto);
            }
        }
    }

    /// Makes every sent message due for retransmission at `now`.
    pub fn rewind(&mut self, now: u32, rto: u32) {
        for s in self.q.iter_mut().take(self.sent) {
            s.sent_at = now.wrapping_sub(rto);
        }
    }

    /// Renumbers everything still queued to start at `base` (the peer lost its
    /// state or we have none); all of it will be sent again as new.
    pub fn renumber(&mut self, base: u16, win: u16) {
        self.base = base;
        self.sent = 0;
        self.sent_charge = 0;
        self.credit = win;
    }

    /// Forgets every queued message.
    pub fn clear(&mut self) {
        self.q.clear();
        self.sent = 0;
        self.sent_charge = 0;
    }

    /// The next message to put on the wire at `now`, if any: the oldest
    /// message whose retransmit timer expired, else the next new message
    /// inside the peer's window. Marks it sent at `now`.
    pub fn next_transmit(&mut self, now: u32, rto: u32) -> Option<(u16, &T)> {
        let due = self
            .q
            .iter()
            .take(self.sent)
            .position(|s| now.wrapping_sub(s.sent_at) >= rto);
        let idx = match due {
            Some(i) => {
                self.retransmits = self.retransmits.wrapping_add(1);
                i
            }
            None => {
                if self.sent >= self.q.len() || self.blocked() {
                    return None;
                }
                self.sent_charge += u32::from(self.q.get(self.sent)?.charge);
                self.sent += 1;
                self.sent - 1
            }
        };
        let slot = self.q.get_mut(idx)?;
        slot.sent_at = now;
        Some((self.base.wrapping_add(idx as u16), &slot.msg))
    }

    /// Earliest time at which a retransmission falls due, if anything is in flight.
    pub fn next_timeout(&self, rto: u32) -> Option<u32> {
        self.q
            .iter()
            .take(self.sent)
            .map(|s| s.sent_at.wrapping_add(rto))
            .next()
    }
}

/// What [`RecvLane::on_frame`] did with a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RxOutcome {
    /// Delivered, with this many messages in total (parked ones included).
    Delivered(usize),
    /// Inside the window but after a gap: parked until the gap fills.
    Parked,
    /// After a gap, on a lane that parks nothing ([`DirectLane`]): dropped, the sender sends it
    /// again after the gap.
    Skipped,
    /// Already delivered (or already parked): dropped.
    Duplicate,
    /// Beyond the advertised window: dropped.
    Violation,
}

/// Receiving half of a lane: `N` slots holding the delivered messages the application has
/// not popped yet (the oldest at `head`, then in order) followed by the frames parked after a
/// gap. The free slots are the advertised credit, and a parked frame `d` places after
/// `expected` sits `d` slots after the delivered ones, so one array serves both (a message
/// costs its slot once, whether delivered or parked).
pub struct RecvLane<T, const N: usize> {
    slots: [Option<T>; N],
    /// Slot of the oldest delivered message.
    head: usize,
    /// Delivered messages not yet popped: slots `head .. head + ready` (wrapping).
    ready: usize,
    expected: u16,
    delivered: u32,
    duplicates: u32,
    violations: u32,
}

impl<T, const N: usize> Default for RecvLane<T, N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T, const N: usize> RecvLane<T, N> {
    pub fn new() -> Self {
        Self {
            slots: core::array::from_fn(|_| None),
            head: 0,
            ready: 0,
            expected: 0,
            delivered: 0,
            duplicates: 0,
            violations: 0,
        }
    }

    /// Slot `offset` places after the oldest delivered message.
    fn slot(&self, offset: usize) -> usize {
        (self.head + offset) % N
    }

    /// Next sequence number to deliver (the cumulative ack).
    pub fn expected(&self) -> u16 {
        self.expected
    }

    /// Credit: free slots in the delivery queue.
    pub fn window(&self) -> u16 {
        (N - self.ready).min(u16::MAX as usize) as u16
    }

    /// Messages delivered and not yet popped.
    pub fn ready_len(&self) -> usize {
        self.ready
    }

    /// Messages parked after a gap.
    pub fn parked_len(&self) -> usize {
        (self.ready..N)
            .filter(|&i| self.slots[self.slot(i)].is_some())
            .count()
    }

    /// Counters: (delivered, duplicates, violations).
    pub fn counters(&self) -> (u32, u32, u32) {
        (self.delivered, self.duplicates, self.violations)
    }

    /// Takes the oldest delivered message.
    pub fn pop(&mut self) -> Option<T> {
        if self.ready == 0 {
            return None;
        }
        // `head` is always a slot index (`slot`); `get` leaves no bounds-check panic path.
        let m = self.slots.get_mut(self.head).and_then(Option::take);
        self.head = self.slot(1);
        self.ready -= 1;
        m
    }

    /// Looks at the oldest delivered message without taking it.
    pub fn peek(&self) -> Option<&T> {
        if self.ready == 0 {
            None
        } else {
            self.slots.get(self.head).and_then(Option::as_ref)
        }
    }

    /// Accepts frame `seq` carrying `msg`.
    pub fn on_frame(&mut self, seq: u16, msg: T) -> RxOutcome {
        self.on_frame_with(seq, msg, |_| {})
    }

    /// Like [`on_frame`](Self::on_frame), calling `delivered` for each
    /// message as it is delivered, in order.
    pub fn on_frame_with(&mut self, seq: u16, msg: T, mut delivered: impl FnMut(&T)) -> RxOutcome {
        let d = seq.wrapping_sub(self.expected) as i16;
        if d < 0 {
            self.duplicates = self.duplicates.wrapping_add(1);
            return RxOutcome::Duplicate;
        }
        if d as usize >= self.window() as usize {
            self.violations = self.violations.wrapping_add(1);
            return RxOutcome::Violation;
        }
        if d > 0 {
            // Inside the window: the slot is past the delivered ones and holds either nothing
            // or this very frame (a parked frame keeps its place until delivered).
            let slot = self.slot(self.ready + d as usize);
            if self.slots[slot].is_some() {
                self.duplicates = self.duplicates.wrapping_add(1);
                return RxOutcome::Duplicate;
            }
            self.slots[slot] = Some(msg);
            return RxOutcome::Parked;
        }
        // d == 0 and window >= 1, so there is room.
        let mut n = 0;
        let at = self.slot(self.ready);
        self.slots[at] = Some(msg);
        loop {
            let at = self.slot(self.ready);
            match &self.slots[at] {
                Some(m) if self.ready < N => delivered(m),
                _ => break,
            }
            self.ready += 1;
            self.expected = self.expected.wrapping_add(1);
            n += 1;
        }
        self.delivered = self.delivered.wrapping_add(n as u32);
        RxOutcome::Delivered(n)
    }

    /// Restarts the sequence space at `expected`, dropping parked frames
    /// (delivered messages stay for the application).
    pub fn reset(&mut self, expected: u16) {
        self.expected = expected;
        for i in self.ready..N {
            let at = self.slot(i);
            self.slots[at] = None;
        }
    }
}

/// What an endpoint needs of its queued lane's receiving half, whichever kind it is.
pub trait QueuedRecv {
    /// Next sequence number to deliver (the cumulative ack).
    fn expected(&self) -> u16;
    /// The credit to advertise after `expected`.
    fn window(&self) -> u16;
    /// The whole credit when nothing waits (for the handshake).
    fn capacity(&self) -> u16;
    /// Restarts the sequence space at `expected` (see [`RecvLane::reset`]).
    fn reset(&mut self, expected: u16);
    /// Counters: (delivered, duplicates, violations).
    fn counters(&self) -> (u32, u32, u32);
}

impl<T, const N: usize> QueuedRecv for RecvLane<T, N> {
    fn expected(&self) -> u16 {
        RecvLane::expected(self)
    }
    fn window(&self) -> u16 {
        RecvLane::window(self)
    }
    fn capacity(&self) -> u16 {
        N.min(u16::MAX as usize) as u16
    }
    fn reset(&mut self, expected: u16) {
        RecvLane::reset(self, expected)
    }
    fn counters(&self) -> (u32, u32, u32) {
        RecvLane::counters(self)
    }
}

/// Receiving half of a lane with no queue of its own (the board's queued lane): each frame that
/// comes in order goes straight to the application, which stores what it keeps (program lines in
/// its line ring) and whose free room is the credit. A frame after a gap is dropped: parking it
/// would need room the missing frames may take, so the sender goes back to the gap instead
/// (`SendLane::rewind` on a NAK).
pub struct DirectLane {
    expected: u16,
    /// The application's free room, as it last said ([`DirectLane::set_window`]).
    window: u16,
    capacity: u16,
    delivered: u32,
    duplicates: u32,
    violations: u32,
}

impl DirectLane {
    /// A lane whose application can hold `capacity` units.
    pub const fn new(capacity: u16) -> Self {
        Self {
            expected: 0,
            window: capacity,
            capacity,
            delivered: 0,
            duplicates: 0,
            violations: 0,
        }
    }

    /// The application's free room now; true when it grew (worth a window update).
    pub fn set_window(&mut self, window: u16) -> bool {
        let grew = window > self.window;
        self.window = window;
        grew
    }

    /// Frame `seq`: `deliver` hands its message to the application and returns whether it was
    /// taken (false: it did not fit or did not decode; it is then not acknowledged).
    pub fn on_frame(&mut self, seq: u16, deliver: impl FnOnce() -> bool) -> RxOutcome {
        let d = seq.wrapping_sub(self.expected) as i16;
        if d < 0 {
            self.duplicates = self.duplicates.wrapping_add(1);
            return RxOutcome::Duplicate;
        }
        if d > 0 {
            return RxOutcome::Skipped;
        }
        if !deliver() {
            self.violations = self.violations.wrapping_add(1);
            return RxOutcome::Violation;
        }
        self.expected = self.expected.wrapping_add(1);
        self.delivered = self.delivered.wrapping_add(1);
        RxOutcome::Delivered(1)
    }
}

impl QueuedRecv for DirectLane {
    fn expected(&self) -> u16 {
        self.expected
    }
    fn window(&self) -> u16 {
        self.window
    }
    fn capacity(&self) -> u16 {
        self.capacity
    }
    fn reset(&mut self, expected: u16) {
        self.expected = expected;
    }
    fn counters(&self) -> (u32, u32, u32) {
        (self.delivered, self.duplicates, self.violations)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn receiver_orders_and_dedups() {
        let mut r: RecvLane<u32, 4> = RecvLane::new();
        assert_eq!(r.on_frame(1, 11), RxOutcome::Parked);
        assert_eq!(r.on_frame(1, 11), RxOutcome::Duplicate);
        assert_eq!(r.on_frame(4, 14), RxOutcome::Violation);
        assert_eq!(r.on_frame(0, 10), RxOutcome::Delivered(2));
        assert_eq!(r.on_frame(0, 10), RxOutcome::Duplicate);
        assert_eq!(r.window(), 2);
        assert_eq!(r.pop(), Some(10));
        assert_eq!(r.pop(), Some(11));
        assert_eq!(r.expected(), 2);
    }

    /// The receiver against a plain model (a delivery queue and a map of parked frames), over
    /// random frames, pops and resets.
    #[test]
    fn receiver_matches_a_queue_and_map_model() {
        extern crate std;
        use std::collections::{BTreeMap, VecDeque};
        const N: usize = 5;
        let mut r: RecvLane<u32, N> = RecvLane::new();
        let (mut expected, mut ready, mut parked) = (0u16, VecDeque::new(), BTreeMap::new());
        let mut seed = 12345u64;
        let mut rnd = |m: u64| {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 33) % m
        };
        for step in 0..200_000u32 {
            match rnd(10) {
                0..=5 => {
                    let seq = expected.wrapping_add(rnd(9) as u16).wrapping_sub(2);
                    let msg = step;
                    let d = seq.wrapping_sub(expected) as i16;
                    let want = if d < 0 {
                        RxOutcome::Duplicate
                    } else if d as usize >= N - ready.len() {
                        RxOutcome::Violation
                    } else if d > 0 {
                        match parked.entry(seq) {
                            std::collections::btree_map::Entry::Occupied(_) => RxOutcome::Duplicate,
                            std::collections::btree_map::Entry::Vacant(v) => {
                                v.insert(msg);
                                RxOutcome::Parked
                            }
                        }
                    } else {
                        ready.push_back(msg);
                        expected = expected.wrapping_add(1);
                        let mut n = 1;
                        while let Some(m) = parked.remove(&expected) {
                            ready.push_back(m);
                            expected = expected.wrapping_add(1);
                            n += 1;
                        }
                        RxOutcome::Delivered(n)
                    };
                    let mut seen = std::vec::Vec::new();
                    assert_eq!(r.on_frame_with(seq, msg, |m| seen.push(*m)), want, "{step}");
                    if let RxOutcome::Delivered(n) = want {
                        let from = ready.len() - n;
                        assert_eq!(&seen[..], &ready.make_contiguous()[from..]);
                    }
                }
                6..=8 => assert_eq!(r.pop(), ready.pop_front(), "{step}"),
                _ => {
                    let to = rnd(100) as u16;
                    r.reset(to);
                    expected = to;
                    parked.clear();
                }
            }
            assert_eq!(r.expected(), expected);
            assert_eq!(r.ready_len(), ready.len());
            assert_eq!(r.parked_len(), parked.len());
            assert_eq!(r.window() as usize, N - ready.len());
            assert_eq!(r.peek(), ready.front());
        }
    }

    #[test]
    fn sender_spends_byte_credit_and_goes_back_on_a_nak() {
        let mut s: SendLane<u32, 8> = SendLane::new();
        for (i, charge) in [(0, 100), (1, 0), (2, 150), (3, 60)] {
            s.push(i, charge).unwrap();
        }
        s.on_ack(0, 250);
        // 100 + 0 + 150 = 250 fits; the fourth (60) does not.
        let sent: std::vec::Vec<u16> =
            core::iter::from_fn(|| s.next_transmit(0, 10).map(|(q, _)| q)).collect();
        assert_eq!(sent, [0, 1, 2]);
        assert!(s.blocked());
        // An older advertisement for the same ack with less credit changes nothing.
        s.on_ack(0, 100);
        assert_eq!(s.credit(), 250);
        // Two acknowledged: the credit now counts from seq 2 (150 + 60 > 200).
        assert_eq!(s.on_ack(2, 200), 2);
        assert!(s.next_transmit(1, 10).is_none());
        assert_eq!(s.on_ack(2, 210), 0);
        assert_eq!(s.next_transmit(1, 10).map(|(q, _)| q), Some(3));
        // A NAK for seq 2 with go-back makes 2 and 3 due again at once.
        s.on_nak(2, 5, 10, true);
        let again: std::vec::Vec<u16> =
            core::iter::from_fn(|| s.next_transmit(5, 10).map(|(q, _)| q)).collect();
        assert_eq!(again, [2, 3]);
    }

    #[test]
    fn direct_lane_delivers_in_order_and_drops_the_rest() {
        let mut d = DirectLane::new(500);
        let mut taken = std::vec::Vec::new();
        assert_eq!(d.on_frame(1, || unreachable!()), RxOutcome::Skipped);
        assert_eq!(
            d.on_frame(0, || {
                taken.push(0);
                true
            }),
            RxOutcome::Delivered(1)
        );
        assert_eq!(d.on_frame(0, || unreachable!()), RxOutcome::Duplicate);
        // Refused by the application (no room): not delivered, counted.
        assert_eq!(d.on_frame(1, || false), RxOutcome::Violation);
        assert_eq!(
            d.on_frame(1, || {
                taken.push(1);
                true
            }),
            RxOutcome::Delivered(1)
        );
        assert_eq!(taken, [0, 1]);
        assert_eq!(d.counters(), (2, 1, 1));
        assert!(!d.set_window(400));
        assert!(d.set_window(450));
        assert_eq!(QueuedRecv::window(&d), 450);
    }

    #[test]
    fn sender_respects_window_and_retransmits() {
        let mut s: SendLane<u32, 8> = SendLane::new();
        for i in 0..5 {
            s.push(i, 1).unwrap();
        }
        s.on_ack(0, 2);
        assert_eq!(s.next_transmit(0, 10).map(|(q, m)| (q, *m)), Some((0, 0)));
        assert_eq!(s.next_transmit(0, 10).map(|(q, m)| (q, *m)), Some((1, 1)));
        assert!(s.next_transmit(1, 10).is_none());
        assert!(s.blocked());
        // Timeout: oldest first.
        assert_eq!(s.next_transmit(10, 10).map(|(q, _)| q), Some(0));
        assert_eq!(s.on_ack(1, 2), 1);
        assert_eq!(s.credit(), 2);
        // Seq 1 (sent at 0) is overdue and goes before the new seq 2.
        assert_eq!(s.next_transmit(11, 10).map(|(q, _)| q), Some(1));
        assert_eq!(s.next_transmit(11, 10).map(|(q, _)| q), Some(2));
        assert!(s.next_transmit(11, 10).is_none());
        // A bogus ack beyond what was sent is ignored.
        assert_eq!(s.on_ack(9, 9), 0);
        assert_eq!(s.base(), 1);
    }
}

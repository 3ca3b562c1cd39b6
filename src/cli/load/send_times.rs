//! When each stream's producer sent each frame, so that a viewer can tell a frame's
//! producer-to-viewer latency from its sequence number: a ring of recent send times per
//! stream, written by the producer and read by the viewers, on one clock.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// Frames remembered per stream: at 240 fps, 4 s of frames.
const SLOTS: usize = 1024;

pub struct SendTimes {
    clock: Instant,
    /// `(seq + 1) << 32 | micros`, packed so a slot is read whole; 0 is empty.
    slots: Vec<AtomicU64>,
}

impl SendTimes {
    pub fn new(clock: Instant) -> SendTimes {
        SendTimes {
            clock,
            slots: (0..SLOTS).map(|_| AtomicU64::new(0)).collect(),
        }
    }

    /// Microseconds on this run's clock.
    pub fn now_us(&self) -> u64 {
        self.clock.elapsed().as_micros() as u64
    }

    /// Records that frame `seq` is sent now.
    pub fn sent(&self, seq: u64) {
        let packed = ((seq + 1) << 32) | (self.now_us() & 0xffff_ffff);
        self.slots[seq as usize % SLOTS].store(packed, Ordering::Release);
    }

    /// Milliseconds since frame `seq` was sent, if it is still remembered.
    pub fn age_ms(&self, seq: u64) -> Option<f64> {
        let sent = self.sent_us(seq)?;
        let now = self.now_us() & 0xffff_ffff;
        Some(micros_between(sent, now) as f64 / 1e3)
    }

    /// Microseconds between the sends of frames `earlier` and `later`, if both are still
    /// remembered.
    pub fn send_gap_us(&self, earlier: u64, later: u64) -> Option<u64> {
        Some(micros_between(self.sent_us(earlier)?, self.sent_us(later)?))
    }

    /// When frame `seq` was sent: microseconds on this run's clock, modulo 2^32.
    fn sent_us(&self, seq: u64) -> Option<u64> {
        let packed = self.slots[seq as usize % SLOTS].load(Ordering::Acquire);
        (packed >> 32 == (seq + 1) & 0xffff_ffff).then_some(packed & 0xffff_ffff)
    }
}

/// `later - earlier` for microseconds modulo 2^32 (71 minutes): the difference wraps
/// correctly.
fn micros_between(earlier: u64, later: u64) -> u64 {
    u64::from(later.wrapping_sub(earlier) as u32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_sent_frame_ages_and_an_overwritten_one_is_forgotten() {
        let times = SendTimes::new(Instant::now());
        times.sent(5);
        std::thread::sleep(std::time::Duration::from_millis(20));
        let age = times.age_ms(5).unwrap();
        assert!((20.0..1000.0).contains(&age), "{age}");
        assert_eq!(times.age_ms(6), None);
        times.sent(6);
        let gap = times.send_gap_us(5, 6).unwrap();
        assert!((20_000..1_000_000).contains(&gap), "{gap}");
        assert_eq!(times.send_gap_us(5, 7), None);
        times.sent(5 + SLOTS as u64);
        assert_eq!(times.age_ms(5), None);
    }
}

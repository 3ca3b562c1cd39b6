//! The producer's gate: frames must come in order (`seq` increasing, `t` not
//! decreasing) and at most `max_fps` per second on average, in bursts of a quarter second.
//! A token bucket on tokio's clock, so tests can pause time.

use tokio::time::Instant;

use super::ingest::Refusal;
use crate::stream::Frame;
use facewire_proto::codes::ErrorCode;

pub struct ProducerGate {
    last: Option<(u64, f64)>,
    tokens: f64,
    burst: f64,
    max_fps: f64,
    refilled: Instant,
}

impl ProducerGate {
    pub fn new(max_fps: f64) -> ProducerGate {
        let burst = (max_fps / 4.0).max(2.0);
        ProducerGate {
            last: None,
            tokens: burst,
            burst,
            max_fps,
            refilled: Instant::now(),
        }
    }

    /// Lets `frame` through, or says why not.
    pub fn admit(&mut self, frame: &Frame) -> Result<(), Refusal> {
        if let Some((seq, time)) = self.last {
            if frame.seq <= seq {
                return Err(Refusal::new(
                    ErrorCode::OutOfOrder,
                    Some("seq"),
                    format!("seq {} does not follow {seq}", frame.seq),
                ));
            }
            if frame.time_s < time {
                return Err(Refusal::new(
                    ErrorCode::OutOfOrder,
                    Some("t"),
                    format!("t {} s is before the previous frame's {time} s", frame.time_s),
                ));
            }
        }
        let now = Instant::now();
        self.tokens = (self.tokens + (now - self.refilled).as_secs_f64() * self.max_fps).min(self.burst);
        self.refilled = now;
        if self.tokens < 1.0 {
            return Err(Refusal::new(
                ErrorCode::RateLimited,
                None,
                format!("more than {} frames per second", self.max_fps),
            ));
        }
        self.tokens -= 1.0;
        self.last = Some((frame.seq, frame.time_s));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    fn frame(seq: u64, t: f64) -> Frame {
        Frame::at(seq, t)
    }

    #[tokio::test(start_paused = true)]
    async fn bursts_pass_then_the_average_rate_holds() {
        let mut gate = ProducerGate::new(40.0);
        // A burst of 10 (a quarter second at 40 fps) passes at once; the 11th does not.
        for seq in 0..10 {
            gate.admit(&frame(seq, 0.0)).unwrap();
        }
        let refusal = gate.admit(&frame(10, 0.0)).unwrap_err();
        assert_eq!(refusal.code, ErrorCode::RateLimited);
        // 100 ms later four more tokens have come.
        tokio::time::advance(Duration::from_millis(100)).await;
        for seq in 10..14 {
            gate.admit(&frame(seq, 0.1)).unwrap();
        }
        assert!(gate.admit(&frame(14, 0.1)).is_err());
        // At exactly 40 fps a producer is never refused.
        for seq in 15..415 {
            tokio::time::advance(Duration::from_millis(25)).await;
            gate.admit(&frame(seq, seq as f64)).unwrap();
        }
    }

    #[tokio::test(start_paused = true)]
    async fn order_is_checked_before_the_rate() {
        let mut gate = ProducerGate::new(1000.0);
        gate.admit(&frame(5, 1.0)).unwrap();
        let refusal = gate.admit(&frame(5, 2.0)).unwrap_err();
        assert_eq!(
            (refusal.code, refusal.field.as_deref()),
            (ErrorCode::OutOfOrder, Some("seq"))
        );
        let refusal = gate.admit(&frame(6, 0.5)).unwrap_err();
        assert_eq!(
            (refusal.code, refusal.field.as_deref()),
            (ErrorCode::OutOfOrder, Some("t"))
        );
        gate.admit(&frame(6, 1.0)).unwrap();
    }
}

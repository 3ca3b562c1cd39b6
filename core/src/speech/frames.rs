//! The frames a voice makes: [`VisemeFrames`] samples the tracker's 10 ms decisions at the
//! stream's frame rate on the stream's clock, each frame holding the viseme decided
//! nearest its time as FAP 1 (both selects, blend 63), which moves the mouth, jaw and
//! tongue through [`crate::stream::visemes::VISEMES`] as a text-to-speech viseme track
//! would.

use super::log_mel::{HOP, SAMPLE_RATE_HZ};
use crate::stream::visemes::single;
use crate::stream::Frame;

/// Frames at `fps` from decisions, on the stream's clock (seconds).
pub struct VisemeFrames {
    fps: f64,
    /// Frame 0's time; frame `k` is at `origin_s + k / fps`.
    origin_s: f64,
    /// The next frame's number.
    next: u64,
}

impl VisemeFrames {
    pub fn new(fps: f64, origin_s: f64) -> Self {
        VisemeFrames {
            fps,
            origin_s,
            next: 0,
        }
    }

    fn time_s(&self, k: u64) -> f64 {
        self.origin_s + k as f64 / self.fps
    }

    /// The next frame's time, s.
    pub fn next_s(&self) -> f64 {
        self.time_s(self.next)
    }

    /// Takes the next decision, centred at `time_s` on the stream's clock, and calls
    /// `on_frame` for each frame whose nearest decision it is (the frames up to half a
    /// step after its centre).
    pub fn push(&mut self, time_s: f64, viseme: u8, mut on_frame: impl FnMut(Frame)) {
        let half_step_s = HOP as f64 / f64::from(SAMPLE_RATE_HZ) / 2.0;
        while self.next_s() < time_s + half_step_s {
            on_frame(self.frame(viseme));
        }
    }

    /// The voice stops at `end_s`: the frames before it still owed, showing `viseme`.
    pub fn finish(&mut self, viseme: u8, end_s: f64, mut on_frame: impl FnMut(Frame)) {
        while self.next_s() < end_s {
            on_frame(self.frame(viseme));
        }
    }

    /// The next frame only, showing `viseme`.
    pub fn one(&mut self, viseme: u8) -> Frame {
        self.frame(viseme)
    }

    /// No frames until `t_s` (a pause in the voice): the next frame is the first at or
    /// after it.
    pub fn skip_to(&mut self, t_s: f64) {
        // Less than a microsecond early is the same instant (rounding).
        let k = ((t_s - self.origin_s) * self.fps - 1e-6 * self.fps).ceil();
        if k.is_finite() && k > self.next as f64 {
            self.next = k as u64;
        }
    }

    fn frame(&mut self, viseme: u8) -> Frame {
        let frame = Frame {
            seq: self.next,
            time_s: self.next_s(),
            viseme: Some(single(viseme)),
            ..Frame::default()
        };
        self.next += 1;
        frame
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::speech::log_mel::frame_centre_s;

    #[test]
    fn each_frame_takes_the_decision_nearest_its_time() {
        // 25 fps: frames at 0, 40, 80 ms; decisions centred at 12.5, 22.5, ... ms.
        let mut sampler = VisemeFrames::new(25.0, 0.0);
        let mut frames = Vec::new();
        for i in 0..10 {
            sampler.push(frame_centre_s(i), i as u8, |f| frames.push(f));
        }
        sampler.finish(9, 0.2, |f| frames.push(f));
        let visemes: Vec<i32> = frames.iter().map(|f| f.viseme.unwrap().select1).collect();
        // 0 ms -> decision 0 (12.5 ms); 40 -> 3 (42.5); 80 -> 7 (82.5); 120, 160 -> the last.
        assert_eq!(visemes, [0, 3, 7, 9, 9]);
        let times: Vec<f64> = frames.iter().map(|f| f.time_s).collect();
        assert_eq!(times, [0.0, 0.04, 0.08, 0.12, 0.16]);
        assert!(frames.iter().enumerate().all(|(k, f)| f.seq == k as u64));
    }
}

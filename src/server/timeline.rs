//! Latest-frame-wins with ends that are never lost. A stream's parameters and a
//! pipeline's encoded frames travel through watch channels holding a [`Timeline`]: the
//! newest frame, and the newest end together with the frame it ended. A reader that was
//! busy skips middle frames, but always gets the last frame before an end, then the end,
//! then whatever came after, in that order. Every frame and end has a serial number
//! (increasing along the stream, frames and ends alike) that readers remember.

use std::sync::Arc;

use facewire_proto::codes::EndReason;

/// A value with its serial number.
#[derive(Debug)]
pub struct Stamped<T> {
    pub serial: u64,
    pub value: Arc<T>,
}

impl<T> Clone for Stamped<T> {
    fn clone(&self) -> Self {
        Stamped {
            serial: self.serial,
            value: self.value.clone(),
        }
    }
}

#[derive(Debug)]
struct End<T> {
    serial: u64,
    reason: EndReason,
    /// The newest frame when the stream ended: never skipped.
    last: Option<Stamped<T>>,
}

impl<T> Clone for End<T> {
    fn clone(&self) -> Self {
        End {
            serial: self.serial,
            reason: self.reason,
            last: self.last.clone(),
        }
    }
}

/// One thing a reader has to handle, in order.
#[derive(Debug)]
pub enum Step<T> {
    Frame(Stamped<T>),
    End { serial: u64, reason: EndReason },
}

impl<T> Step<T> {
    pub fn serial(&self) -> u64 {
        match self {
            Step::Frame(s) => s.serial,
            Step::End { serial, .. } => *serial,
        }
    }
}

/// The newest frame and the newest end of a stream.
#[derive(Debug)]
pub struct Timeline<T> {
    latest: Option<Stamped<T>>,
    end: Option<End<T>>,
    /// The highest serial used so far.
    serial: u64,
}

impl<T> Default for Timeline<T> {
    fn default() -> Self {
        Timeline {
            latest: None,
            end: None,
            serial: 0,
        }
    }
}

impl<T> Timeline<T> {
    /// Adds a frame with the next serial; returns the serial.
    pub fn publish(&mut self, value: Arc<T>) -> u64 {
        let serial = self.serial + 1;
        self.publish_at(serial, value);
        serial
    }

    /// Adds a frame with a serial given by an upstream timeline (larger than any so far).
    pub fn publish_at(&mut self, serial: u64, value: Arc<T>) {
        debug_assert!(serial > self.serial, "serials increase");
        self.serial = serial;
        self.latest = Some(Stamped { serial, value });
    }

    /// Ends the stream with the next serial, unless it has already ended with nothing
    /// since (so a producer's disconnect after a head deletion ends it once). Returns the
    /// serial when an end was added.
    pub fn end(&mut self, reason: EndReason) -> Option<u64> {
        if self.has_ended() {
            return None;
        }
        let serial = self.serial + 1;
        self.end_at(serial, reason);
        Some(serial)
    }

    /// Ends the stream with a serial given by an upstream timeline.
    pub fn end_at(&mut self, serial: u64, reason: EndReason) {
        debug_assert!(serial > self.serial, "serials increase");
        self.serial = serial;
        self.end = Some(End {
            serial,
            reason,
            last: self.latest.clone(),
        });
    }

    /// Whether the newest event is an end.
    pub fn has_ended(&self) -> bool {
        self.end.as_ref().is_some_and(|e| e.serial == self.serial)
    }

    /// Where a reader that joins now starts: it will get the newest frame (and the end
    /// after it, if the stream has ended), nothing older.
    pub fn join_point(&self) -> u64 {
        self.latest.as_ref().map_or(self.serial, |l| l.serial - 1)
    }

    /// What a reader that has handled everything up to serial `done` must handle now,
    /// oldest first: the frame an end ended, the end, and the newest frame after it; each
    /// only when newer than `done`. At most three steps.
    pub fn steps_after(&self, done: u64) -> impl Iterator<Item = Step<T>> {
        let mut steps: [Option<Step<T>>; 3] = [None, None, None];
        let mut after = done;
        if let Some(end) = self.end.as_ref().filter(|e| e.serial > done) {
            if let Some(last) = end.last.as_ref().filter(|l| l.serial > done) {
                steps[0] = Some(Step::Frame(last.clone()));
            }
            steps[1] = Some(Step::End {
                serial: end.serial,
                reason: end.reason,
            });
            after = end.serial;
        }
        if let Some(latest) = self.latest.as_ref().filter(|l| l.serial > after) {
            steps[2] = Some(Step::Frame(latest.clone()));
        }
        steps.into_iter().flatten()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn serials(t: &Timeline<&'static str>, done: u64) -> Vec<String> {
        t.steps_after(done)
            .map(|s| match s {
                Step::Frame(f) => format!("{}:{}", f.serial, f.value),
                Step::End { serial, reason } => format!("{serial}:end {reason}"),
            })
            .collect()
    }

    #[test]
    fn a_busy_reader_skips_middle_frames_but_never_the_last_before_an_end() {
        let mut t = Timeline::default();
        assert_eq!(serials(&t, 0), Vec::<String>::new());
        t.publish(Arc::new("a"));
        t.publish(Arc::new("b"));
        assert_eq!(serials(&t, 0), ["2:b"]);
        t.publish(Arc::new("c"));
        assert_eq!(t.end(EndReason::ProducerEnded), Some(4));
        // A reader that last saw "a" skips "b", gets "c", then the end.
        assert_eq!(serials(&t, 1), ["3:c", "4:end producer_ended"]);
        // A reader that saw "c" gets the end alone.
        assert_eq!(serials(&t, 3), ["4:end producer_ended"]);
        assert_eq!(serials(&t, 4), Vec::<String>::new());
        // A second end with nothing between is not an end.
        assert_eq!(t.end(EndReason::ProducerDisconnected), None);
        // The next producer's frames come after the end.
        t.publish(Arc::new("d"));
        t.publish(Arc::new("e"));
        assert_eq!(serials(&t, 2), ["3:c", "4:end producer_ended", "6:e"]);
        assert_eq!(serials(&t, 4), ["6:e"]);
    }

    #[test]
    fn joiners_get_the_newest_frame_and_an_end_after_it() {
        let mut t: Timeline<&'static str> = Timeline::default();
        assert_eq!(serials(&t, t.join_point()), Vec::<String>::new());
        t.publish(Arc::new("a"));
        t.publish(Arc::new("b"));
        assert_eq!(serials(&t, t.join_point()), ["2:b"]);
        t.end(EndReason::BatchFinished);
        assert_eq!(serials(&t, t.join_point()), ["2:b", "3:end batch_finished"]);
        t.publish(Arc::new("c"));
        assert_eq!(serials(&t, t.join_point()), ["4:c"]);
        // An end with no frame at all.
        let mut empty: Timeline<&'static str> = Timeline::default();
        empty.end(EndReason::HeadDeleted);
        assert_eq!(serials(&empty, 0), ["1:end head_deleted"]);
    }

    #[test]
    fn downstream_timelines_keep_upstream_serials() {
        let mut up: Timeline<&'static str> = Timeline::default();
        let mut down: Timeline<String> = Timeline::default();
        up.publish(Arc::new("a"));
        up.publish(Arc::new("b"));
        up.end(EndReason::ProducerIdle);
        for step in up.steps_after(1) {
            match step {
                Step::Frame(f) => down.publish_at(f.serial, Arc::new(f.value.to_uppercase())),
                Step::End { serial, reason } => down.end_at(serial, reason),
            }
        }
        let steps: Vec<u64> = down.steps_after(0).map(|s| s.serial()).collect();
        assert_eq!(steps, [2, 3]);
        assert!(down.has_ended());
    }
}

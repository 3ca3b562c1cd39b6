//! Tells a watch that has stopped delivering from one that is only behind. A key-value
//! watch can stall without an error (its consumer being made again, over and over, while
//! the bus fails over); a node following it would then never see a head registered
//! elsewhere. The follower compares, every [`super::heads`] check, the newest revision in
//! the bucket with the newest the watch delivered: a revision the bucket held at one
//! check and the watch had still not delivered at the next is a stalled watch.

/// What the last checks saw; starts with nothing outstanding.
#[derive(Debug, Default)]
pub struct WatchLag {
    /// The bucket's newest revision at the last check, when the watch had not delivered it.
    outstanding: Option<u64>,
    /// The revision the watch was last made again for: it is not waited for again. A
    /// revision removed from the bucket's stream by hand is never delivered, and costs one
    /// new watch, not one a check; a newer revision is waited for as any.
    watched_again_for: Option<u64>,
}

impl WatchLag {
    /// One check: `in_bucket` the bucket's newest revision now, `delivered` the newest the
    /// watch has delivered. True when the watch is stalled (what was outstanding at the
    /// previous check is still not delivered) and is to be made again.
    pub fn stalled(&mut self, in_bucket: u64, delivered: u64) -> bool {
        if let Some(revision) = self.outstanding.take() {
            if delivered < revision {
                self.watched_again_for = Some(revision);
                return true;
            }
        }
        if delivered < in_bucket && self.watched_again_for != Some(in_bucket) {
            self.outstanding = Some(in_bucket);
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_watch_that_keeps_up_is_never_stalled() {
        let mut lag = WatchLag::default();
        assert!(!lag.stalled(0, 0));
        assert!(!lag.stalled(5, 5));
        assert!(!lag.stalled(9, 9));
    }

    #[test]
    fn behind_at_one_check_and_caught_up_by_the_next_is_not_stalled() {
        let mut lag = WatchLag::default();
        // Revision 7 written just before the check: in flight.
        assert!(!lag.stalled(7, 6));
        // Delivered by the next check, while 9 is new and in flight again.
        assert!(!lag.stalled(9, 7));
        assert!(!lag.stalled(9, 9));
    }

    #[test]
    fn a_revision_outstanding_over_a_whole_check_is_a_stall() {
        let mut lag = WatchLag::default();
        assert!(!lag.stalled(7, 6));
        assert!(lag.stalled(7, 6));
        // Watched again from the start: a fresh watch gets one whole period again.
        assert!(!lag.stalled(7, 0));
        assert!(!lag.stalled(7, 7));
        // Stalled again later, on a newer revision: watched again.
        assert!(!lag.stalled(12, 7));
        assert!(lag.stalled(12, 7));
    }

    #[test]
    fn a_revision_no_watch_delivers_costs_one_new_watch() {
        // Revision 7 was removed from the stream by hand: the bucket's newest is 7, a watch
        // delivers 6 at most.
        let mut lag = WatchLag::default();
        assert!(!lag.stalled(7, 6));
        assert!(lag.stalled(7, 6));
        for _ in 0..5 {
            assert!(!lag.stalled(7, 6));
        }
        // A new revision is watched for again.
        assert!(!lag.stalled(8, 6));
        assert!(lag.stalled(8, 6));
    }

    #[test]
    fn a_bucket_made_again_starts_its_revisions_over() {
        let mut lag = WatchLag::default();
        assert!(!lag.stalled(40, 40));
        // The bucket was deleted and made again: its newest revision is below what was
        // delivered; nothing is outstanding.
        assert!(!lag.stalled(2, 40));
        assert!(!lag.stalled(2, 40));
    }
}

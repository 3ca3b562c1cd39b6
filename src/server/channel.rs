//! One stream of one head: the latest parameters (latest-frame-wins), the single
//! producer slot, and the deform pipelines viewers subscribe to, one per (algorithm,
//! face roughness) no matter how many viewers watch it.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use glam::Vec3;
use tokio::sync::watch;

use super::pipeline::{Output, Pipeline};

/// Parameters of one accepted frame, resolved to the mask.
#[derive(Debug, Clone, PartialEq)]
pub struct Params {
    pub seq: u64,
    pub time_s: f64,
    pub label: Option<String>,
    /// When the server received it, µs since the Unix epoch.
    pub received_us: u64,
    /// One weight per animation unit.
    pub animation: Vec<f32>,
    /// One offset per mask vertex (raw controls, ARKit), mask units.
    pub offsets: Vec<Vec3>,
}

/// What a channel's subscribers see: nothing yet, the newest frame, or the end.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    Idle,
    Frame(Arc<Params>),
    Ended(String),
}

pub struct Channel {
    pub name: String,
    events: watch::Sender<Event>,
    producer: Mutex<Option<u64>>,
    pipelines: Mutex<HashMap<(String, bool), Arc<Pipeline>>>,
}

impl Channel {
    pub fn new(name: &str) -> Channel {
        Channel {
            name: name.to_string(),
            events: watch::Sender::new(Event::Idle),
            producer: Mutex::new(None),
            pipelines: Mutex::new(HashMap::new()),
        }
    }

    /// Takes the producer slot for `producer`; false when another producer holds it.
    pub fn claim_producer(&self, producer: u64) -> bool {
        let mut slot = self.producer.lock().expect("producer lock");
        match *slot {
            Some(_) => false,
            None => {
                *slot = Some(producer);
                true
            }
        }
    }

    pub fn release_producer(&self, producer: u64) {
        let mut slot = self.producer.lock().expect("producer lock");
        if *slot == Some(producer) {
            *slot = None;
        }
    }

    pub fn has_producer(&self) -> bool {
        self.producer.lock().expect("producer lock").is_some()
    }

    /// Publishes the newest parameters; subscribers that are busy skip older ones.
    pub fn publish(&self, params: Params) {
        self.events.send_replace(Event::Frame(Arc::new(params)));
    }

    pub fn end(&self, reason: &str) {
        self.events.send_replace(Event::Ended(reason.to_string()));
    }

    pub fn subscribe(&self) -> watch::Receiver<Event> {
        self.events.subscribe()
    }

    /// A receiver of the pipeline for `(spec, face)`, starting the pipeline when none
    /// runs. `start` builds it; it runs until its last viewer leaves.
    pub fn watch_pipeline(
        self: &Arc<Self>,
        key: (String, bool),
        start: impl FnOnce(watch::Receiver<Event>) -> Arc<Pipeline>,
    ) -> watch::Receiver<Output> {
        let mut pipelines = self.pipelines.lock().expect("pipelines lock");
        if let Some(p) = pipelines.get(&key).filter(|p| !p.is_stopped()) {
            return p.subscribe();
        }
        let mut events = self.subscribe();
        events.mark_changed();
        let pipeline = start(events);
        let rx = pipeline.subscribe();
        pipelines.insert(key, pipeline);
        rx
    }

    /// Called by a pipeline with no viewers left: removes it unless a viewer joined
    /// meanwhile (checked under the same lock viewers join under). True when removed.
    pub fn retire_pipeline(&self, key: &(String, bool), pipeline: &Pipeline) -> bool {
        let mut pipelines = self.pipelines.lock().expect("pipelines lock");
        if pipeline.viewer_count() > 0 {
            return false;
        }
        pipeline.stop();
        if pipelines
            .get(key)
            .is_some_and(|p| std::ptr::eq(p.as_ref(), pipeline))
        {
            pipelines.remove(key);
        }
        true
    }

    pub fn pipeline_count(&self) -> usize {
        self.pipelines.lock().expect("pipelines lock").len()
    }
}

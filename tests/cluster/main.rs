//! The cluster's integration tests: facewire nodes over real NATS servers with JetStream
//! (`bus`: shared heads, relayed streams and voices, leases, failures and forgeries;
//! `auth`: credentials, TLS and mutual TLS; `trust`: a registry and leases no stranger on
//! the bus can change, buckets that come back, a three-server NATS cluster losing one).
//! Apart from the other suites, so that their timeouts are measured on a machine busy only
//! with them.

#[path = "../common/mod.rs"]
mod common;

mod auth;
mod bus;
mod trust;

//! The service's integration tests: `facewire serve` and the router through real sockets,
//! abuse and bounded work, the CLI's subcommands, the load generator, parts on the wire,
//! and the JavaScript and Python clients against a live server. One binary (one link);
//! each file is a module named as it was.

#[path = "../common/mod.rs"]
mod common;

mod abuse;
mod bounded_work;
mod cli;
mod glb_registration;
mod load;
mod parts;
mod python_client;
mod replay;
mod replay_voice;
mod routes;
mod serve_process;
mod server;
mod texture;
mod web_decode;

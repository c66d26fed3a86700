//! motet-node's integration tests, one binary (each file a module): the
//! suite builds and links one test program for the crate instead of one a
//! file.

mod batch;
mod common;
mod describe;
mod exactness;
mod fixed_time;
mod frames;
mod graph_channels;
mod graph_components;
mod graph_latency;
mod graph_record;
mod graph_wheelbot;
mod graph_wire;
mod heater;
mod poll_budget;
mod refusals;
mod safe_stop;
mod services;
mod servo;
mod tools;
mod underrun;

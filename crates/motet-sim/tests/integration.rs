//! motet-sim's integration tests, one binary (each file a module): the
//! suite builds and links one test program for the crate instead of one a
//! file.

mod constant_memory;
mod dance_game_controller;
mod dance_pantograph;
mod dance_recording;
mod dance_stencil;
mod heaters;
mod observer;
mod safe_stop;
mod servo;
mod stop_horizon;
